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
//! # Not covered
//!
//! The Hertz law (refused: [`VARIATIONAL_MODAL_NO_HERTZ`]); parameter columns
//! (the orbit layer takes parameter derivatives by central differences of the map).

// Index loops read as the linear algebra they are.
#![allow(clippy::needless_range_loop)]

use super::lyapunov_spectrum::Frame;
use super::variational::{EventCounts, Phase, Step, VARIATIONAL_NEEDS_BALL};

/// Why the modal variational layer refuses the Hertz law.
pub const VARIATIONAL_MODAL_NO_HERTZ: &str = "the N-mode bar's variational flow covers the instantaneous restitution law; the hertz law's tangent maps through compliant contact phases are the lumped bar's only so far";
use crate::damper::friction::{sgn0, sliding_friction_on_ball_n};
use crate::damper::impact::modal_inverse_effective_mass_per_kg;
use crate::error::SimError;
use crate::limits::MAX_BEAM_MODES;
use crate::params::{ContactLaw, FrictionModel};
use crate::solver::exact::constrained::ConstrainedModes;
use crate::solver::exact::modal::ModalExact;
use crate::solver::modal_rk4::ModalObserver;
use crate::solver::{Event, EventKind, Mode, Observer, RunSummary, Segment};
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
}

impl Cs {
    fn new(sys: &ModalSystem) -> Result<Cs, SimError> {
        let d = sys
            .damper
            .ok_or(SimError::Unsupported(VARIATIONAL_NEEDS_BALL))?;
        if d.contact.law == ContactLaw::Hertz {
            return Err(SimError::Unsupported(VARIATIONAL_MODAL_NO_HERTZ));
        }
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
    }

    /// Re-orthonormalise every two steps in the coordinates scaled by `scale` (Lyapunov).
    pub(crate) fn with_qr(mut self, scale: VecD) -> Self {
        let d = self.dim();
        self.qr = Some(Box::new(Qr {
            scale,
            frame: Frame::new(d, self.cs.e, false),
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

    /// Apply what is still pending (an event at the very end of the run).
    pub fn finish(&mut self) {
        if let Some(p) = self.pending.take() {
            let after = Phase::default_after(&p.ev, self.cur);
            let contact = matches!(after.mode, Mode::Contact(_));
            self.resolve(p, after, contact);
        }
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
    let n = var.cs.n;
    let x_end = to_vec(n, &r.final_state);
    let end_phase = var.cur.unwrap_or(Phase {
        mode: Mode::Free,
        sigma: sgn0(r.final_state.dw_m_s(&sys.model)),
    });
    let f = var.cs.field(end_phase, &x_end, t_end_s);
    Ok(ModalFlowJacobian {
        state: r.final_state,
        jacobian: var.jacobian(),
        end_field: f[..var.dim()].to_vec(),
        events: var.counts,
        summary: r.summary,
    })
}
