//! The N-mode bar ([`ModalExact`]) as a bar of the one variational layer
//! ([`super`], whose module docs derive the saltation matrix
//! `S = G + (f⁺ − G f⁻) ∇hᵀ / (∇h·f⁻ + ∂h/∂t)`, the compliant phase's tangent map and what the
//! layer does at each event): this module gives the modal ingredients ([`ModalBar`]) and carries
//! the tangent columns ([`ModalTangent`]).
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
//! The layer's construction ([`super`], "Hertz contact phases") with the contact
//! row: in the contact coordinates `y = (q, q̇, δ, δ̇)`, `δ = s(v − φ_dᵀq) − l_g`,
//! `δ̇ = s(v̇ − φ_dᵀq̇)`, the field of `solver/exact/modal/hertz.rs`
//! (`mₙq̈ₙ + cₙq̇ₙ + kₙqₙ = φ_fn F(t) + φ_dn(s P − F_b)`, `m_d v̈ = −s P + F_b`) has the Jacobian
//! rows `q̈ₙ: (−kₙ, −cₙ, φ_dn s P_δ, φ_dn s P_δ̇)/mₙ` and `δ̈ = s(−s δP/m_d − φ_dᵀq̈)`, whose
//! `δ` entry is `−P_δ κ` (`κ = 1/m_d + Σφ_dn²/mₙ`; the lumped `1/M + 1/m_d`). The memory
//! row has `∇w = (−φ_d, 0, 1, 0)`, `∇ẇ = (0, −φ_d, 0, 1)`; the phase's map `T⁻¹(W + ζcᵀ)` is
//! applied to the carried columns at the release. Stuck inside a contact: the held modes, `δ`
//! frozen; unstick at `h = f_l ∓ (a_b/κ + s K_h δ^{3/2})`. The `D + 1` columns of `[W | ζ]`
//! are integrated one by one (each its own adaptive Dormand–Prince 5(4) at
//! [`HERTZ_TANGENT_RTOL`], along the solver's dense output; the lumped bar's block at once),
//! `O(N)` per column and stage. `A(t)` reads only `δ`, `δ̇`, from the segment's public state.
//!
//! Not covered: parameter columns ([`super`], "Not covered").

// Index loops read as the linear algebra they are.
#![allow(clippy::needless_range_loop)]

use super::{
    contact_partials, tangent_advance, ContactPhase, EventCounts, EventMap, Laws, Phase, Step,
    TangentBar, Variational, HERTZ_TANGENT_RTOL, VARIATIONAL_NEEDS_BALL,
};
use crate::analysis::lyapunov_spectrum::Frame;
use crate::damper::impact::modal_inverse_effective_mass_per_kg;
use crate::error::SimError;
use crate::limits::MAX_BEAM_MODES;
use crate::solver::dopri5::Dopri5;
use crate::solver::exact::constrained::ConstrainedModes;
use crate::solver::exact::modal::ModalExact;
use crate::solver::modal_rk4::ModalObserver;
use crate::solver::{CompliantContact, Event, Mode, RunSummary, Segment};
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
    kappa: f64,
    laws: Laws,
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
            kappa: 0.0,
            laws: Laws::new(
                &d,
                sys.friction_level_n(),
                &sys.forcing,
                sys.omega_rad_s(),
                sys.omega1_rad_s(),
            ),
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
        cs.kappa = modal_inverse_effective_mass_per_kg(cs.laws.md, &cs.phi_d[..n], &cs.m[..n]);
        Ok(cs)
    }

    fn dim(&self) -> usize {
        2 * self.n + 2
    }

    /// `φ_dᵀ y[offset..offset+N]`.
    fn dot_d(&self, y: &VecD, offset: usize) -> f64 {
        (0..self.n).map(|i| self.phi_d[i] * y[offset + i]).sum()
    }

    /// The vector field of phase `p` at `x`, `t`.
    fn field(&self, p: Phase, x: &VecD, t: f64) -> VecD {
        let n = self.n;
        let f_t = self.laws.force(t);
        let mut f = [0.0; D_MAX];
        let mut a_b = 0.0;
        for i in 0..n {
            f[i] = x[n + i];
            let b = self.phi_f[i] * f_t - self.c[i] * x[n + i] - self.k[i] * x[i];
            f[n + i] = b / self.m[i];
            a_b += self.phi_d[i] * b / self.m[i];
        }
        f[2 * n] = x[2 * n + 1];
        // The force of the bar on the ball: sliding friction in free flight; held, the force
        // that gives the ball (under its body force `m_d g_s`) the cavity's acceleration,
        // `(a_b − g_s)/κ`.
        let fball = match p.mode {
            Mode::Free | Mode::NoBall => self.laws.fb(p.sigma),
            Mode::Stick | Mode::Contact(_) => (a_b - self.laws.gs) / self.kappa,
        };
        for i in 0..n {
            f[n + i] -= self.phi_d[i] * fball / self.m[i];
        }
        f[2 * n + 1] = fball / self.laws.md + self.laws.gs;
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
        y[2 * n + 1] -= p / self.laws.md;
    }
}

/// The compliant (`hertz`) contact phase's tangent equation in the contact coordinates
/// `y = (q, q̇, δ, δ̇)`, `δ = s(v − φ_dᵀq) − l_g`, `δ̇ = s(v̇ − φ_dᵀq̇)` (module docs).
impl Cs {
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
        let (p_d, p_dd, p_v0) = contact_partials(c, delta, ddelta);
        let dp = p_d * z[2 * n] + p_dd * z[2 * n + 1] + p_v0 * gamma;
        let mut acc = 0.0;
        for i in 0..n {
            dz[n + i] = (b[i] + self.phi_d[i] * sw * dp) / self.m[i];
            acc += self.phi_d[i] * dz[n + i];
        }
        dz[2 * n] = z[2 * n + 1];
        dz[2 * n + 1] = sw * (-sw * dp / self.laws.md - acc);
        dz
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

/// The N-mode bar of the variational layer: its constants, the constrained modes of the ball
/// held (computed when a run first holds it), and the compliant phase's block `[W | ζ]` as
/// `D + 1` columns with each column's tangent step.
pub struct ModalBar {
    cs: Cs,
    sys: ModalSystem,
    held: Option<Box<ConstrainedModes>>,
    psi: Box<[[f64; 2 * NM]; 2 * NM]>,
    z: Box<[VecD; D_MAX + 1]>,
    h: [f64; D_MAX + 1],
}

/// Where the modal tangent maps go: the carried tangent vectors (the columns of `Y`,
/// `Y ← (tangent map) Y`), updated in place, the modal state now, and the spectrum's frame.
pub struct ModalTangent {
    /// The tangent vectors (columns of `Y`).
    pub cols: Box<[VecD; D_MAX]>,
    /// How many columns are carried.
    pub ncols: usize,
    /// The modal state now (end of the last segment, or after the last event).
    x_cur: VecD,
    /// Re-orthonormalisation (Lyapunov spectrum), when set.
    qr: Option<Box<Qr>>,
}

/// The variational layer of a modal exact run: a [`ModalObserver`] carrying the columns of
/// [`ModalTangent`] through every segment and event.
pub type ModalVariational = Variational<ModalTangent, ModalBar>;

/// QR re-orthonormalisation state: the spectrum's frame
/// ([`crate::analysis::lyapunov_spectrum::Frame`]) in the coordinates scaled by `scale`.
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

impl ModalTangent {
    /// Count a step with the frame; re-orthonormalise when it is due
    /// (`lyapunov_spectrum::STEPS_PER_QR`).
    fn step_done(&mut self, step: Step) {
        if self.qr.as_deref_mut().is_some_and(|q| q.frame.note(&step)) {
            self.flush();
        }
    }

    /// Re-orthonormalise now (Gram–Schmidt in the scaled coordinates), adding `ln Rᵢᵢ` to the
    /// logs.
    fn flush(&mut self) {
        let d = self.ncols;
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

impl ModalVariational {
    /// The layer for `sys` (a ball, either contact law) starting at `init`, carrying the
    /// identity (the Jacobian).
    pub fn new_modal(sys: &ModalSystem, init: &ModalState) -> Result<ModalVariational, SimError> {
        sys.validate()?;
        let cs = Cs::new(sys)?;
        let d = cs.dim();
        let mut cols = Box::new([[0.0; D_MAX]; D_MAX]);
        for (j, c) in cols.iter_mut().enumerate().take(d) {
            c[j] = 1.0;
        }
        let bar = ModalBar {
            cs,
            sys: sys.clone(),
            held: None,
            psi: Box::new([[0.0; 2 * NM]; 2 * NM]),
            z: Box::new([[0.0; D_MAX]; D_MAX + 1]),
            h: [0.0; D_MAX + 1],
        };
        let sink = ModalTangent {
            cols,
            ncols: d,
            x_cur: to_vec(cs.n, init),
            qr: None,
        };
        Ok(Variational::with_bar(bar, sink))
    }

    /// State dimension `2N + 2`.
    pub fn dim(&self) -> usize {
        self.bar.cs.dim()
    }

    /// Restart the carried columns' run at `init` (between runs of one spectrum).
    pub(crate) fn restart_at(&mut self, init: &ModalState) {
        self.sink.x_cur = to_vec(self.bar.cs.n, init);
        self.cur = None;
        self.pending = None;
        self.hz = None;
    }

    /// Re-orthonormalise every two steps in the coordinates scaled by `scale` (Lyapunov).
    pub(crate) fn with_qr(mut self, scale: VecD) -> Self {
        let d = self.dim();
        let compliant = self.bar.cs.laws.hertz.is_some();
        self.sink.qr = Some(Box::new(Qr {
            scale,
            frame: Frame::new(d, self.bar.cs.laws.e, compliant),
        }));
        // Start from the identity in scaled coordinates: column j is s_j e_j.
        for j in 0..d {
            self.sink.cols[j] = [0.0; D_MAX];
            self.sink.cols[j][j] = scale[j];
        }
        self
    }

    pub(crate) fn qr_state(&mut self) -> Option<&mut Qr> {
        self.sink.qr.as_deref_mut()
    }

    /// Re-orthonormalise now.
    pub(crate) fn flush(&mut self) {
        self.sink.flush();
    }

    /// The Jacobian carried so far (`Y` as a `D × D` matrix, row-major).
    pub fn jacobian(&self) -> Vec<Vec<f64>> {
        let d = self.dim();
        (0..d)
            .map(|i| (0..self.sink.ncols).map(|j| self.sink.cols[j][i]).collect())
            .collect()
    }
}

impl ModalBar {
    /// Apply the free-flight transition over `τ` to every column.
    fn apply_free(&self, sink: &mut ModalTangent, tau: f64) {
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
        for y in sink.cols.iter_mut().take(sink.ncols) {
            for (i, b) in blocks.iter().enumerate().take(n) {
                let (a, da) = (y[i], y[n + i]);
                y[i] = b[0] * a + b[1] * da;
                y[n + i] = b[2] * a + b[3] * da;
            }
            y[2 * n] += tau * y[2 * n + 1];
        }
    }

    /// Apply the held transition (projection, then `Ψ(τ)`) to every column.
    fn apply_held(&mut self, sink: &mut ModalTangent, mode: Mode, tau: f64) {
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
        for y in sink.cols.iter_mut().take(sink.ncols) {
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

    /// `det(W + ζcᵀ)/det W = 1 + cᵀW⁻¹ζ` of the phase just closed (Gaussian elimination with
    /// partial pivoting in the tolerance's scaled coordinates, on the block, which the phase
    /// no longer needs); 0 where `W` is singular (a stick removed a direction).
    fn memory_factor(&mut self, ph: &ContactPhase<VecD>) -> f64 {
        let (n, d) = (self.cs.n, self.cs.dim());
        if ph.c[..d].iter().all(|c| *c == 0.0) {
            return 1.0;
        }
        let (row, col) = (|i| ph.row_scale(n, i), |j| ph.col_scale(n, j));
        // a = R W C (columns 0..d), r = R ζ (column d); cᵀW⁻¹ζ = (Cc)ᵀ a⁻¹ r.
        let a = &mut self.z;
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
            for c in a.iter_mut().take(d + 1).skip(k) {
                c.swap(k, p);
            }
            for i in k + 1..d {
                let f = a[k][i] / piv;
                for c in a.iter_mut().take(d + 1).skip(k) {
                    c[i] -= f * c[k];
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
}

impl TangentBar<ModalTangent> for ModalBar {
    type X = VecD;
    /// `None` is the identity, `Some(e)` the modal impact law at `e`.
    type G = Option<f64>;
    fn dim(&self) -> usize {
        self.cs.dim()
    }
    fn zero(&self) -> VecD {
        [0.0; D_MAX]
    }
    fn laws(&self) -> &Laws {
        &self.cs.laws
    }
    /// `1/κ`.
    fn contact_mass_kg(&self) -> f64 {
        1.0 / self.cs.kappa
    }
    fn event_state(&self, sink: &ModalTangent, _: &Event) -> VecD {
        sink.x_cur
    }
    /// The modes as the last step left them, the ball as the phase restarts it (`ẇ = 0`
    /// exactly after a friction event).
    fn state_at_start(&self, sink: &ModalTangent, seg: &dyn Segment, t0: f64) -> VecD {
        let n = self.cs.n;
        let p0 = seg.state_at(t0);
        let mut x = sink.x_cur;
        x[2 * n] = p0.v_m;
        x[2 * n + 1] = p0.dv_m_s;
        x
    }
    fn field(&self, p: Phase, x: &VecD, t: f64) -> VecD {
        self.cs.field(p, x, t)
    }
    fn dw(&self, x: &VecD) -> f64 {
        let n = self.cs.n;
        x[2 * n + 1] - self.cs.dot_d(x, n)
    }
    fn grad_w(&self) -> VecD {
        let n = self.cs.n;
        let mut g = [0.0; D_MAX];
        for i in 0..n {
            g[i] = -self.cs.phi_d[i];
        }
        g[2 * n] = 1.0;
        g
    }
    fn grad_dw(&self) -> VecD {
        let n = self.cs.n;
        let mut g = [0.0; D_MAX];
        for i in 0..n {
            g[n + i] = -self.cs.phi_d[i];
        }
        g[2 * n + 1] = 1.0;
        g
    }
    /// `h = a_b` (times `1/κ`, a common factor that cancels in `S`).
    fn hold_release(&self, t: f64, f_minus: &VecD) -> (VecD, f64) {
        let cs = &self.cs;
        let n = cs.n;
        let mut grad = [0.0; D_MAX];
        let mut dh_dt = 0.0;
        for i in 0..n {
            grad[i] = -cs.phi_d[i] * cs.k[i] / cs.m[i];
            grad[n + i] = -cs.phi_d[i] * cs.c[i] / cs.m[i];
            dh_dt += cs.phi_d[i] * cs.phi_f[i] / cs.m[i];
        }
        let rate =
            (0..cs.dim()).map(|i| grad[i] * f_minus[i]).sum::<f64>() + dh_dt * cs.laws.dforce_dt(t);
        (grad, rate)
    }
    fn identity_g(&self) -> Option<f64> {
        None
    }
    fn impact_g(&self, plastic: bool) -> Option<f64> {
        Some(if plastic { 0.0 } else { self.cs.laws.e })
    }
    fn after_reset(&self, g: &Option<f64>, _: bool, _: &Event, x: &VecD) -> VecD {
        let mut x_plus = *x;
        if let Some(e) = *g {
            self.cs.impact_law(e, &mut x_plus);
        }
        x_plus
    }
    fn segment_map(
        &mut self,
        sink: &mut ModalTangent,
        _: &dyn Segment,
        mode: Mode,
        t0: f64,
        t1: f64,
    ) {
        match mode {
            Mode::Free | Mode::NoBall => self.apply_free(sink, t1 - t0),
            Mode::Stick | Mode::Contact(_) => self.apply_held(sink, mode, t1 - t0),
        }
        sink.step_done(Step::Segment {
            t0_s: t0,
            t1_s: t1,
            mode,
        });
    }
    fn event_map(&mut self, sink: &mut ModalTangent, e: &EventMap<VecD, Option<f64>>) {
        let cs = &self.cs;
        let d = cs.dim();
        let mut gf = e.f_minus;
        if let Some(r) = e.g {
            cs.impact_law(r, &mut gf);
        }
        let mut a = [0.0; D_MAX];
        for i in 0..d {
            a[i] = (e.f_plus[i] - gf[i]) / e.rate;
        }
        for y in sink.cols.iter_mut().take(sink.ncols) {
            let th: f64 = (0..d).map(|i| e.grad_h[i] * y[i]).sum();
            if let Some(r) = e.g {
                cs.impact_law(r, y);
            }
            if e.ok {
                for i in 0..d {
                    y[i] += a[i] * th;
                }
            }
        }
        sink.step_done(Step::Event {
            t_s: e.t_s,
            kind: e.kind,
            plastic: e.plastic,
        });
    }
    fn mark(&mut self, sink: &mut ModalTangent, step: Step) {
        sink.step_done(step);
    }

    /// `y` of a public vector `x` at wall `sw`.
    fn contact_coords(&self, sw: f64, x: &VecD) -> VecD {
        let n = self.cs.n;
        let mut y = *x;
        y[2 * n] = sw * (x[2 * n] - self.cs.dot_d(x, 0)) - self.cs.laws.lg;
        y[2 * n + 1] = sw * (x[2 * n + 1] - self.cs.dot_d(x, n));
        y
    }

    /// A tangent vector in contact coordinates back to public ones (`δv = φ_dᵀδq + s δδ`).
    fn public_tangent(&self, sw: f64, z: &VecD) -> VecD {
        let n = self.cs.n;
        let mut x = *z;
        x[2 * n] = self.cs.dot_d(z, 0) + sw * z[2 * n];
        x[2 * n + 1] = self.cs.dot_d(z, n) + sw * z[2 * n + 1];
        x
    }

    /// The phase's vector field at `y` (`solver/exact/modal/hertz.rs`): the modes under the
    /// force `s P − F_b` at the cavity, `m_d v̈ = −s P + F_b`, `δ̈ = s(v̈ − φ_dᵀq̈)`; stuck: the
    /// ball held (the force `−a_b/κ` on the bar), `δ` frozen.
    fn hz_field(&self, c: &CompliantContact, t: f64, y: &VecD) -> VecD {
        let n = self.cs.n;
        let f_t = self.cs.laws.force(t);
        let mut f = [0.0; D_MAX];
        let mut b = [0.0; NM];
        let mut a_b = 0.0;
        for i in 0..n {
            b[i] = self.cs.phi_f[i] * f_t - self.cs.c[i] * y[n + i] - self.cs.k[i] * y[i];
            a_b += self.cs.phi_d[i] * b[i] / self.cs.m[i];
        }
        let sw = c.wall_sign;
        let (on_bar, p) = if c.stuck {
            (-a_b / self.cs.kappa, 0.0)
        } else {
            let p = c.law.force_n(y[2 * n], y[2 * n + 1], c.reference_speed_m_s);
            (sw * p - c.ball_friction_n, p)
        };
        let mut acc = 0.0;
        for i in 0..n {
            f[i] = y[n + i];
            f[n + i] = (b[i] + self.cs.phi_d[i] * on_bar) / self.cs.m[i];
            acc += self.cs.phi_d[i] * f[n + i];
        }
        if !c.stuck {
            f[2 * n] = y[2 * n + 1];
            f[2 * n + 1] = sw * ((-sw * p + c.ball_friction_n) / self.cs.laws.md - acc);
        }
        f
    }

    /// `h = f_l ∓ (a_b/κ + s K_h δ^{3/2})` (the solver's test): the hold test's `∇h` (of `a_b`,
    /// the same in contact coordinates) and the elastic force's `δ` entry, both times `κ`.
    fn hz_unstick(
        &self,
        sw: f64,
        c: &CompliantContact,
        t: f64,
        y: &VecD,
        f_minus: &VecD,
    ) -> (VecD, f64) {
        let n = self.cs.n;
        let (mut g, rate) = self.hold_release(t, f_minus);
        g[2 * n] = self.cs.kappa * sw * 1.5 * c.law.stiffness_n_m32 * y[2 * n].max(0.0).sqrt();
        (g, rate + g[2 * n] * f_minus[2 * n])
    }
    fn hz_col(&self, j: usize) -> VecD {
        self.z[j]
    }
    fn hz_set_col(&mut self, j: usize, z: &VecD) {
        self.z[j] = *z;
    }
    fn hz_begin(&mut self, h0: f64) {
        self.h = [h0; D_MAX + 1];
    }
    /// Column by column: `z' = A(t) z` (`+ b(t)` for `ζ`), relative tolerance
    /// [`HERTZ_TANGENT_RTOL`] on every entry.
    fn hz_advance(&mut self, ph: &ContactPhase<VecD>, seg: &dyn Segment) -> Result<(), SimError> {
        let cs = self.cs;
        let (n, d) = (cs.n, cs.dim());
        let (sw, info, a, b) = (ph.sw, &ph.last, seg.t_start_s(), seg.t_end_s());
        for j in 0..=d {
            let mut atol = [0.0; D_MAX];
            for (i, at) in atol.iter_mut().enumerate().take(d) {
                *at = HERTZ_TANGENT_RTOL * ph.row_scale(n, i) / ph.col_scale(n, j);
            }
            let ig = Dopri5::<D_MAX> {
                rtol: HERTZ_TANGENT_RTOL,
                atol,
                len: d,
            };
            let gamma = if j == d { 1.0 } else { 0.0 };
            let f = |t: f64, z: &VecD| {
                let x = seg.state_at(t);
                cs.hz_tangent(info, sw * x.w_m() - cs.laws.lg, sw * x.dw_m_s(), z, gamma)
            };
            tangent_advance(&ig, f, a, b, &mut self.z[j], &mut self.h[j])?;
        }
        Ok(())
    }
    /// `y ← T⁻¹ (W y + ζ (cᵀy))` on every carried column.
    fn phase_map(
        &mut self,
        sink: &mut ModalTangent,
        ph: &ContactPhase<VecD>,
        t_end: f64,
    ) -> Option<f64> {
        let cs = &self.cs;
        let d = cs.dim();
        let z = &self.z;
        for y in sink.cols.iter_mut().take(sink.ncols) {
            let g: f64 = (0..d).map(|j| ph.c[j] * y[j]).sum();
            let mut m = [0.0; D_MAX];
            for i in 0..d {
                m[i] = z[d][i] * g + (0..d).map(|j| z[j][i] * y[j]).sum::<f64>();
            }
            *y = self.public_tangent(ph.sw, &m);
        }
        sink.step_done(Step::Segment {
            t0_s: ph.t0,
            t1_s: t_end,
            mode: ph.mode,
        });
        let memory = self.memory_factor(ph);
        (memory != 0.0 && memory.is_finite()).then_some(memory)
    }
}

impl ModalObserver for ModalVariational {
    fn modal_step(&mut self, _a: &ModalState, b: &ModalState) {
        self.sink.x_cur = to_vec(self.bar.cs.n, b);
        if let Some(p) = self.pending.as_mut() {
            // Not reached: a segment resolves the pending event first.
            p.x = self.sink.x_cur;
        }
    }

    fn modal_impact(&mut self, before: &ModalState, after: &ModalState, _loss: f64) {
        if let Some(p) = self.pending.as_mut() {
            p.x = to_vec(self.bar.cs.n, before);
        }
        self.sink.x_cur = to_vec(self.bar.cs.n, after);
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
    let mut var = ModalVariational::new_modal(sys, init)?;
    let r = ModalExact::default().run_modal(sys, init, t_end_s, &mut var)?;
    var.conclude()?;
    let f = var.end_field(t_end_s, &to_vec(var.bar.cs.n, &r.final_state));
    Ok(ModalFlowJacobian {
        state: r.final_state,
        jacobian: var.jacobian(),
        end_field: f[..var.dim()].to_vec(),
        events: var.counts,
        summary: r.summary,
    })
}
