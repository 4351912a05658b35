//! Closed-form motion of a modal bar with the ball held at the cavity (stick, wall contact).
//!
//! **Equations.** While the ball sticks to the bar (coulomb friction) or rides pressed on a
//! cavity wall, it moves with the cavity point: `v = φ_dᵀq + const`. Its only force along the
//! bar's motion is the one the bar exerts on it, `f_c = m_d v̈ = m_d φ_dᵀq̈`, and the bar gets
//! `−f_c` at `x_d`. Eliminating `f_c`:
//!
//! `M_c q̈ + C q̇ + K q = φ_f F(t)`, `M_c = diag(mₙ) + m_d φ_dφ_dᵀ`, `C = diag(cₙ)`,
//! `K = diag(kₙ)`, `kₙ = mₙωₙ²`, `cₙ = 2ζₙ√(kₙmₙ)`, `F(t) = F_s + F0 sin Ωt` at `x_f`.
//!
//! **Sign of the holding force.** [`ConstrainedMotion::holding_force`] is `f_c(τ) = m_d φ_dᵀq̈`,
//! the force the bar exerts ON the ball, positive in the `+u` (`+w`, `+v`) direction: the
//! lumped solver's `m_d ü_pair`. Stick and wall contact share this motion and differ only in
//! the test the event search applies to `f_c`: stick holds while `|f_c| ≤ f` (the friction
//! capacity of `damper::friction`); on wall `s = ±1` (`w = s·l_g`) the wall can only push the
//! ball towards `−s`, so contact holds while `s·f_c ≤ f_hold` (0 without friction).
//!
//! **Closed form.** `q(τ) = q_s + Im(X e^{iΩ(t0+τ)}) + Σₖ cₖ xₖ e^{sₖτ}`, `τ = t − t0`:
//! * `q_s = K⁻¹φ_f F_s` (exact: `M_c` plays no part);
//! * `X` solves `(K − Ω²M_c + iΩC) X = φ_f F0` (complex LU with one refinement step, once per
//!   run since Ω is fixed);
//! * `(sₖ, xₖ)` are the 2N eigenpairs of the quadratic problem `(s²M_c + sC + K)x = 0`. Because
//!   `M_c` is a rank-one update of a diagonal and `C`, `K` are diagonal, the eigenvector is known
//!   in closed form, `xₖ ∝ D(sₖ)⁻¹φ_d` with `dₙ(s) = mₙs² + cₙs + kₙ`, and the eigenvalues are the
//!   roots of the secular equation `1/(s²m_d) + Σₙ φ_dn²/dₙ(s) = 0` (its undamped form is
//!   `1 = m_dλΣφₙ²/(mₙ(ωₙ² − λ))`, `s² = −λ`). Modal damping is NOT diagonal in these modes; no
//!   proportional-damping assumption is made.
//! * The coefficients come from the orthogonality of the symmetric linearisation
//!   `A = [[C, M_c],[M_c, 0]]`, `ψₖ = [xₖ; sₖxₖ]`: `cₖ = ψₖᵀA y0 / ψₖᵀAψₖ` with
//!   `ψₖᵀAψₖ = xₖᵀ(2sₖM_c + C)xₖ` (plain transpose, no conjugation). Per segment this is two
//!   complex dot products per eigenvalue, `O(N²)`, no allocation.
//!
//! **Eigenvalues.** Once per run: initial values from the real Schur form (nalgebra) of the
//! balanced `2N×2N` first-order matrix in the coordinates `η = diag(√mₙ)q`
//! (`[[0, W],[−PW, −PZ]]`, `W = diag ωₙ`, `Z = diag cₙ/mₙ`, `P = (I + ggᵀ)⁻¹`, `gₙ = √(m_d/mₙ)φ_dn`),
//! then each is polished by Newton's method on the secular function written around its nearest
//! pole `u` (`s = u + δ`, `h(δ) = w_n + p_n(s)G(s)`, monic `p_e(s) = (s − p_e)(s − p̄_e)`, weights
//! `w_e = Σφ_dn²/mₙ`), every factor `s − p_e` evaluated as `δ + (u − p_e)`: the difference of two
//! poles is exact to one rounding, so a mode whose cavity shape is tiny (the ball near one of its
//! nodes: an eigenvalue within `O(φ_dn²)` of its pole) or two nearly equal poles keep `δ`, hence
//! `xₖ`, to full precision. A mode with `φ_dn = 0` exactly is decoupled: its own eigenpair (`pₙ`,
//! unit vector) is taken as is, so a ball at a node leaves that mode unconstrained, to the bit.
//! Modes whose poles are equal bit for bit (equal `ωₙ`, `ζₙ`, e.g. measured modes) are one entry
//! of the secular function; the `r − 1` combinations that leave the cavity still keep that pole
//! (semisimple, not defective) and are added as `diag(m)`-orthogonal vectors with `φ_dᵀv = 0`.
//!
//! With every `ζₙ < 1` (what [`ModalSystem::validate`] allows) every `dₙ(s) > 0` on the real
//! axis, so the secular function has no real root: all constrained modes are underdamped, every
//! term has `ω_d > 0`. A real guess from the Schur form (a nearly critically damped constrained
//! mode) is polished from just above the axis; [`TermSum`] still allows `ω_d = 0` terms.
//!
//! **Repeated eigenvalues.** Equal and nearly equal poles are handled as above (tested with
//! relative splits from 0 to 1e-4 against an RK4). Distinct constrained eigenvalues that lie
//! close together would make the expansion ill-conditioned (the two terms cancel): the relative
//! precision lost is about `ε/ρ`, with `ρₖ = |ψₖᵀAψₖ| / (Σ|xₖⱼ|²(2|sₖ|mⱼ + cⱼ) + 2|sₖ|m_d|φ_dᵀxₖ|²)`
//! (1 for a lone mode, 0 when defective: a double root of the secular function, which needs a
//! constrained mode at critical damping). [`ConstrainedModes::new`] fails with an error naming
//! this quantity if `min ρ < 1e-6` (more than 6 digits lost) or if two polished roots coincide.
//! On the paper beam `min ρ` is 0.20 over every cavity position for N ≤ 32 and ζ ≤ 0.9, and
//! 0.066 with ζ = 0.999 in every mode.
//!
//! **Harmonic phase convention.** Every [`TermSum`] is in the local time `τ = t − t0` of its
//! segment; the harmonic coefficients are already rotated by the segment's start phase `Ωt0`:
//! `value(τ) = constant + cos_omega·cos Ωτ + sin_omega·sin Ωτ + Σ e^{−ατ}(p cos ω_dτ + q sin ω_dτ)`.
//! Every sum of one [`ConstrainedModes`] has the same `N` decaying terms (same `α`, `ω_d`, same
//! order, zero coefficients kept), so a solver can share the transcendental values across them.
//!
//! **Cost.** `new`: one `2N×2N` real Schur form plus `O(N²)` per Newton step per eigenvalue and
//! an `N×N` complex LU (tens of µs, once per run); `segment`: `O(N²)`;
//! `sum_at`/`holding_force`: `O(N)`; `sum` for an arbitrary row: `O(N²)`. Nothing allocates
//! after `new`. Measured (release, shared 2-core machine, medians; the ignored test
//! `timing_of_new_and_segment`): `new` 12 µs (N = 4), 68 µs (N = 12); `segment` +
//! `holding_force` 0.11 µs (N = 4).
//!
//! **Accuracy** (tests `tests/constrained_motion.rs`, measured): N = 1 equals the one-body
//! closed form of mass `M + m_d` to 2.4e-14 of the scale; the paper beam (N = 4, three cavity
//! cases) matches an independent RK4 of the constrained equations to 2.5e-13 of the scale (the
//! RK4's own rounding); the undamped frequencies equal the secular roots by bisection to 1e-13;
//! the energy balance closes to 2.5e-15 of `∫|P|`; the holding force equals `m_d φ_dᵀq̈` from the
//! equation of motion to 1.4e-15; a ball at the beam's node of mode 2 (`φ₂ = 3e-16`) leaves that
//! mode's eigenvalue on its pole to the bit.

use crate::error::{ParamError, SimError};
use crate::limits::{self, MAX_BEAM_MODES};
use crate::structure::{ModalSystem, Point};
use nalgebra::DMatrix;
use num_complex::Complex64;

/// Most terms a constrained motion has: one per eigenvalue representative (a conjugate pair is
/// one term).
pub const MAX_TERMS: usize = 2 * MAX_BEAM_MODES;

/// Smallest allowed conditioning `ρ` of a constrained mode (see the module docs): below it the
/// closed form would lose more than 6 digits to the cancellation of near-repeated eigenvalues.
pub const MIN_MODE_CONDITIONING: f64 = 1e-6;

/// Relative distance under which two polished eigenvalues count as the same root.
const SAME_ROOT_REL: f64 = 1e-10;

/// Newton steps allowed to polish one eigenvalue (it starts within ~1e-13 of the root).
const MAX_NEWTON: usize = 60;

/// A closed form `constant + cos_omega·cos Ωτ + sin_omega·sin Ωτ + Σ e^{−ατ}(p cos ω_dτ + q sin ω_dτ)`
/// in the local time `τ` of a segment (harmonic phase already rotated by the segment start).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TermSum {
    /// Constant part.
    pub constant: f64,
    /// Coefficient of `cos Ωτ`.
    pub cos_omega: f64,
    /// Coefficient of `sin Ωτ`.
    pub sin_omega: f64,
    /// `Ω` (rad/s).
    pub omega_rad_s: f64,
    /// Number of decaying terms used.
    pub n_decays: usize,
    /// Each `[α (1/s), ω_d (rad/s), p, q]`: `e^{−ατ}(p cos ω_dτ + q sin ω_dτ)`; `ω_d = 0` is a
    /// real exponential.
    pub decays: [[f64; 4]; MAX_TERMS],
}

impl TermSum {
    /// The zero sum with harmonic frequency `Ω`.
    pub fn zero(omega_rad_s: f64) -> TermSum {
        TermSum {
            constant: 0.0,
            cos_omega: 0.0,
            sin_omega: 0.0,
            omega_rad_s,
            n_decays: 0,
            decays: [[0.0; 4]; MAX_TERMS],
        }
    }

    /// The decaying terms in use.
    pub fn decays(&self) -> &[[f64; 4]] {
        &self.decays[..self.n_decays]
    }

    /// Value at local time `τ`.
    pub fn value(&self, tau_s: f64) -> f64 {
        let (sh, ch) = (self.omega_rad_s * tau_s).sin_cos();
        let mut v = self.constant + self.cos_omega * ch + self.sin_omega * sh;
        for d in self.decays() {
            let e = (-d[0] * tau_s).exp();
            let (sd, cd) = (d[1] * tau_s).sin_cos();
            v += e * (d[2] * cd + d[3] * sd);
        }
        v
    }

    /// The time derivative, in the same form (exact algebra on the coefficients).
    pub fn deriv(&self) -> TermSum {
        let om = self.omega_rad_s;
        let mut out = TermSum {
            constant: 0.0,
            cos_omega: om * self.sin_omega,
            sin_omega: -om * self.cos_omega,
            omega_rad_s: om,
            n_decays: self.n_decays,
            decays: [[0.0; 4]; MAX_TERMS],
        };
        for (o, d) in out.decays.iter_mut().zip(self.decays()) {
            let [al, wd, p, q] = *d;
            *o = [al, wd, -al * p + wd * q, -al * q - wd * p];
        }
        out
    }

    /// Every coefficient times `k`.
    pub fn scaled(&self, k: f64) -> TermSum {
        let mut out = *self;
        out.constant *= k;
        out.cos_omega *= k;
        out.sin_omega *= k;
        for d in out.decays[..self.n_decays].iter_mut() {
            d[2] *= k;
            d[3] *= k;
        }
        out
    }
}

/// The constrained modes of a modal bar with the ball held at the cavity, and the particular
/// solution of its forcing: everything a segment needs, computed once per run (module docs).
#[derive(Debug, Clone)]
pub struct ConstrainedModes {
    n: usize,
    ball_mass_kg: f64,
    omega_rad_s: f64,
    mass: [f64; MAX_BEAM_MODES],
    damping: [f64; MAX_BEAM_MODES],
    stiffness: [f64; MAX_BEAM_MODES],
    /// `φ` at the cavity, the force point and the response point ([`point_index`]).
    rows: [[f64; MAX_BEAM_MODES]; 3],
    /// Eigenvalue representatives (`Im ≥ 0`; a complex one stands for its conjugate pair).
    n_terms: usize,
    eig: [Complex64; MAX_TERMS],
    paired: [bool; MAX_TERMS],
    vecs: [[Complex64; MAX_BEAM_MODES]; MAX_TERMS],
    /// `(C + sₖM_c)xₖ / aₖ` and `M_c xₖ / aₖ`: `cₖ = w_qₖ·y0 + w_dqₖ·ẏ0`.
    w_q: [[Complex64; MAX_BEAM_MODES]; MAX_TERMS],
    w_dq: [[Complex64; MAX_BEAM_MODES]; MAX_TERMS],
    /// `φ(point)·xₖ` for the three points.
    at_point: [[Complex64; MAX_TERMS]; 3],
    /// Smallest conditioning `ρₖ` (module docs).
    min_conditioning: f64,
    q_static: [f64; MAX_BEAM_MODES],
    q_harm: [Complex64; MAX_BEAM_MODES],
    static_at_point: [f64; 3],
    harm_at_point: [Complex64; 3],
}

fn point_index(p: Point) -> usize {
    match p {
        Point::Cavity => 0,
        Point::Force => 1,
        Point::Response => 2,
    }
}

/// The coupled modes (`φ_dn ≠ 0`) grouped by pole: modes whose poles are equal (bit for bit)
/// enter the secular function as one entry `e` with weight `w_e = Σ φ_dn²/mₙ` over its modes and
/// the monic `p_e(s) = (s − p_e)(s − p̄_e)`, so that `1/(s²m_d) + Σ_e w_e/p_e(s) = 0`.
struct Coupled {
    ne: usize,
    /// Entry of each mode (`usize::MAX`: decoupled, `φ_dn = 0`).
    entry_of: [usize; MAX_BEAM_MODES],
    /// Number of modes in each entry.
    count: [usize; MAX_BEAM_MODES],
    w: [f64; MAX_BEAM_MODES],
    pole: [Complex64; MAX_BEAM_MODES],
    /// `ωₙ` and `cₙ/mₙ` of the entry (for the balanced Schur matrix).
    om: [f64; MAX_BEAM_MODES],
    z: [f64; MAX_BEAM_MODES],
    md: f64,
}

impl Coupled {
    /// `p_j(s)` and `p_j'(s)` at `s = u + δ`, each factor as `δ + (u − pole)`: the difference of
    /// two poles is exact to one rounding, so `s − p_j` keeps full relative precision even when
    /// `s` lies very near `p_j` (a mode barely coupled, or two nearly equal poles).
    fn monic(&self, j: usize, u: Complex64, delta: Complex64) -> (Complex64, Complex64) {
        let f1 = delta + (u - self.pole[j]);
        let f2 = delta + (u - self.pole[j].conj());
        (f1 * f2, f1 + f2)
    }

    /// `G(s) = 1/(s²m_d) + Σ_{e≠skip} w_e/p_e(s)` and `G'(s)`, `s = u + δ`.
    fn g_excluding(&self, u: Complex64, delta: Complex64, skip: usize) -> (Complex64, Complex64) {
        let s = u + delta;
        let s2 = s * s;
        let mut g = 1.0 / (s2 * self.md);
        let mut dg = -2.0 / (s2 * s * self.md);
        for j in (0..self.ne).filter(|&j| j != skip) {
            let (d, dd) = self.monic(j, u, delta);
            g += self.w[j] / d;
            dg -= self.w[j] * dd / (d * d);
        }
        (g, dg)
    }

    /// The pole nearest to `s`: (entry, pole `u`, either `p_e` or `p̄_e`).
    fn nearest(&self, s: Complex64) -> (usize, Complex64) {
        let mut best = (0, self.pole[0], f64::INFINITY);
        for j in 0..self.ne {
            for u in [self.pole[j], self.pole[j].conj()] {
                let dist = (s - u).norm();
                if dist < best.2 {
                    best = (j, u, dist);
                }
            }
        }
        (best.0, best.1)
    }

    /// Newton on `h(δ) = w_n + p_n(u + δ)G(u + δ)` around the pole `u` of entry `n`: returns
    /// `δ` of the polished root `s = u + δ`.
    fn polish_near(&self, n: usize, u: Complex64, s0: Complex64) -> Option<Complex64> {
        let mut delta = s0 - u;
        let wn = self.w[n];
        let mut converged = false;
        let mut last_h = f64::INFINITY;
        for _ in 0..MAX_NEWTON {
            let (g, dg) = self.g_excluding(u, delta, n);
            let (dn, ddn) = self.monic(n, u, delta);
            let h = wn + dn * g;
            let dh = ddn * g + dn * dg;
            let step = h / dh;
            if !(step.re.is_finite() && step.im.is_finite()) {
                return None;
            }
            delta -= step;
            last_h = h.norm() / (wn + (dn * g).norm());
            if step.norm() <= 1e-15 * delta.norm() {
                converged = true;
                break;
            }
        }
        // Rounding can make Newton cycle in the last bit: accept a tiny residual.
        if converged || last_h <= 1e-12 {
            Some(delta)
        } else {
            None
        }
    }

    /// Polish a Schur guess (mapped to `Im ≥ 0`): Newton around its nearest pole, repeated if the
    /// root turns out nearer another pole. Returns `(u, δ)`, the root being `s = u + δ`.
    fn polish(&self, guess: Complex64) -> Option<(Complex64, Complex64)> {
        let mut s = if guess.im < 0.0 { guess.conj() } else { guess };
        if s.im == 0.0 {
            // No real root exists (module docs): start just above the axis.
            s.im = 1e-6 * s.norm().max(f64::MIN_POSITIVE);
        }
        let (mut n, mut u) = self.nearest(s);
        for _ in 0..4 {
            let delta = self.polish_near(n, u, s)?;
            let root = u + delta;
            let (n2, u2) = self.nearest(root);
            if n2 == n && u2 == u {
                return Some((u, delta));
            }
            (n, u, s) = (n2, u2, root);
        }
        None
    }

    /// `1/p_e(s)` of every entry at the root `s = u + δ`: the eigenvector is
    /// `xₙ = φ_dn/(mₙ p_e(n)(s))`.
    fn entry_values(&self, u: Complex64, delta: Complex64) -> [Complex64; MAX_BEAM_MODES] {
        let mut y = [Complex64::new(0.0, 0.0); MAX_BEAM_MODES];
        for (j, yj) in y.iter_mut().enumerate().take(self.ne) {
            *yj = 1.0 / self.monic(j, u, delta).0;
        }
        y
    }
}

fn not_finite(value: f64) -> SimError {
    SimError::Param(ParamError::NonFiniteResult {
        quantity: "constrained modes of the bar with the ball held (stick / wall contact)",
        value,
        cause: "modal masses, stiffnesses, damping or the ball mass outside floating-point range",
    })
}

fn cdot(a: &[Complex64], b: &[f64]) -> Complex64 {
    a.iter()
        .zip(b)
        .fold(Complex64::new(0.0, 0.0), |acc, (x, y)| acc + x * y)
}

impl ConstrainedModes {
    /// The constrained modes and the particular solution, once per run.
    ///
    /// Errors: the system's own validation (field and range named), no ball, more modes than
    /// [`MAX_BEAM_MODES`], an eigenvalue iteration that fails, near-defective constrained modes
    /// (`ρ < MIN_MODE_CONDITIONING`), an undamped constrained resonance, or a non-finite result.
    pub fn new(sys: &ModalSystem) -> Result<ConstrainedModes, SimError> {
        let n = limits::check_count(
            "modes (number of modes of the modal system)",
            sys.n_modes(),
            1,
            MAX_BEAM_MODES,
            "",
        )?;
        sys.validate()?;
        let md = match sys.damper {
            Some(d) => d.ball_mass_kg,
            None => {
                return Err(SimError::Param(ParamError::OutOfRange {
                    field: "damper (the ball: stick and wall contact need one)",
                    value: 0.0,
                    allowed: "a ball with ball_mass_kg > 0",
                }))
            }
        };
        let modes = sys.model.modes();
        let mut cm = ConstrainedModes {
            n,
            ball_mass_kg: md,
            omega_rad_s: sys.omega_rad_s(),
            mass: [0.0; MAX_BEAM_MODES],
            damping: [0.0; MAX_BEAM_MODES],
            stiffness: [0.0; MAX_BEAM_MODES],
            rows: [
                sys.row(Point::Cavity),
                sys.row(Point::Force),
                sys.row(Point::Response),
            ],
            n_terms: 0,
            eig: [Complex64::new(0.0, 0.0); MAX_TERMS],
            paired: [false; MAX_TERMS],
            vecs: [[Complex64::new(0.0, 0.0); MAX_BEAM_MODES]; MAX_TERMS],
            w_q: [[Complex64::new(0.0, 0.0); MAX_BEAM_MODES]; MAX_TERMS],
            w_dq: [[Complex64::new(0.0, 0.0); MAX_BEAM_MODES]; MAX_TERMS],
            at_point: [[Complex64::new(0.0, 0.0); MAX_TERMS]; 3],
            min_conditioning: f64::INFINITY,
            q_static: [0.0; MAX_BEAM_MODES],
            q_harm: [Complex64::new(0.0, 0.0); MAX_BEAM_MODES],
            static_at_point: [0.0; 3],
            harm_at_point: [Complex64::new(0.0, 0.0); 3],
        };
        for (j, m) in modes.iter().enumerate() {
            cm.mass[j] = m.modal_mass_kg;
            cm.stiffness[j] = m.modal_stiffness_n_per_m();
            cm.damping[j] = 2.0 * m.damping_ratio * (cm.stiffness[j] * cm.mass[j]).sqrt();
        }
        let (mass, damping, stiffness) = (cm.mass, cm.damping, cm.stiffness);
        let pole = |j: usize| {
            let a = damping[j] / (2.0 * mass[j]);
            let w = (stiffness[j] / mass[j]).sqrt();
            let z = modes[j].damping_ratio;
            Complex64::new(-a, w * ((1.0 - z) * (1.0 + z)).sqrt())
        };
        let mut cp = Coupled {
            ne: 0,
            entry_of: [usize::MAX; MAX_BEAM_MODES],
            count: [0; MAX_BEAM_MODES],
            w: [0.0; MAX_BEAM_MODES],
            pole: [Complex64::new(0.0, 0.0); MAX_BEAM_MODES],
            om: [0.0; MAX_BEAM_MODES],
            z: [0.0; MAX_BEAM_MODES],
            md,
        };
        let phi_d = cm.rows[0];
        for (j, &pd) in phi_d.iter().enumerate().take(n) {
            let p = pole(j);
            if pd == 0.0 {
                // Decoupled: the ball at a node of this mode leaves it as it is.
                let mut v = [0.0; MAX_BEAM_MODES];
                v[j] = 1.0;
                cm.push_pole_vector(p, &v);
                continue;
            }
            let e = match cp.pole[..cp.ne].iter().position(|&q| q == p) {
                Some(e) => e,
                None => {
                    let e = cp.ne;
                    cp.pole[e] = p;
                    cp.om[e] = (cm.stiffness[j] / cm.mass[j]).sqrt();
                    cp.z[e] = cm.damping[j] / cm.mass[j];
                    cp.ne += 1;
                    e
                }
            };
            cp.entry_of[j] = e;
            cp.count[e] += 1;
            cp.w[e] += pd * pd / cm.mass[j];
        }
        if cp.ne > 0 {
            cm.coupled_modes(&cp)?;
            cm.shared_pole_modes(&cp);
        }
        if cm.min_conditioning < MIN_MODE_CONDITIONING {
            return Err(repeated(cm.min_conditioning));
        }
        if cm.damping[..n].iter().all(|&c| c == 0.0) {
            // Undamped: the roots are on the imaginary axis; Newton leaves rounding-level α.
            for s in cm.eig[..cm.n_terms].iter_mut() {
                s.re = 0.0;
            }
        }
        cm.particular(sys)?;
        for p in 0..3 {
            let row = cm.rows[p];
            for t in 0..cm.n_terms {
                cm.at_point[p][t] = cdot(&cm.vecs[t][..n], &row[..n]);
            }
            cm.static_at_point[p] = row[..n].iter().zip(&cm.q_static).map(|(a, b)| a * b).sum();
            cm.harm_at_point[p] = cdot(&cm.q_harm[..n], &row[..n]);
        }
        cm.check_finite()?;
        Ok(cm)
    }

    /// Add the eigenpair `(s, x)` (and its conjugate) with its orthogonality weights
    /// `w_q = (C + sM_c)x/a`, `w_dq = M_c x/a`, `a = xᵀ(2sM_c + C)x`, and its conditioning `ρ`.
    fn push_pair(&mut self, s: Complex64, x: &[Complex64; MAX_BEAM_MODES]) {
        let n = self.n;
        let md = self.ball_mass_kg;
        let phi = self.rows[0];
        let px = cdot(&x[..n], &phi[..n]);
        let mut a = 2.0 * s * md * px * px;
        let mut scale = 2.0 * s.norm() * md * px.norm_sqr();
        for ((xj, m), c) in x.iter().zip(&self.mass).zip(&self.damping).take(n) {
            a += xj * xj * (2.0 * s * m + c);
            scale += xj.norm_sqr() * (2.0 * s.norm() * m + c);
        }
        self.min_conditioning = self.min_conditioning.min(a.norm() / scale);
        let t = self.n_terms;
        for j in 0..n {
            let mx = self.mass[j] * x[j] + md * phi[j] * px;
            self.w_q[t][j] = (self.damping[j] * x[j] + s * mx) / a;
            self.w_dq[t][j] = mx / a;
        }
        self.eig[t] = s;
        self.paired[t] = true;
        self.vecs[t] = *x;
        self.n_terms += 1;
    }

    /// A pair at an unconstrained pole whose (real) vector does not move the cavity (`φ_dᵀv = 0`).
    fn push_pole_vector(&mut self, s: Complex64, v: &[f64; MAX_BEAM_MODES]) {
        let mut x = [Complex64::new(0.0, 0.0); MAX_BEAM_MODES];
        for (xj, vj) in x.iter_mut().zip(v) {
            *xj = Complex64::new(*vj, 0.0);
        }
        self.push_pair(s, &x);
    }

    /// Modes sharing one pole (`r` of them): `r − 1` combinations leave the cavity still and keep
    /// that pole. In `uⱼ = √mⱼ vⱼ` they are an orthonormal basis of the complement of
    /// `aⱼ = φ_dj/√mⱼ` (Householder columns): `φ_dᵀv = 0` and `vᵀ diag(m) v' = 0`, which makes
    /// them orthogonal to each other in the linearisation (same eigenvalue) as well.
    fn shared_pole_modes(&mut self, cp: &Coupled) {
        for e in (0..cp.ne).filter(|&e| cp.count[e] > 1) {
            let mut js = [0usize; MAX_BEAM_MODES];
            let mut r = 0;
            for j in (0..self.n).filter(|&j| cp.entry_of[j] == e) {
                js[r] = j;
                r += 1;
            }
            let mut hv = [0.0; MAX_BEAM_MODES];
            for i in 0..r {
                hv[i] = self.rows[0][js[i]] / self.mass[js[i]].sqrt();
            }
            let norm = hv[..r].iter().map(|a| a * a).sum::<f64>().sqrt();
            hv[0] += hv[0].signum() * norm;
            let vv: f64 = hv[..r].iter().map(|a| a * a).sum();
            for k in 1..r {
                let mut v = [0.0; MAX_BEAM_MODES];
                for i in 0..r {
                    let h = if i == k { 1.0 } else { 0.0 } - 2.0 * hv[i] * hv[k] / vv;
                    v[js[i]] = h / self.mass[js[i]].sqrt();
                }
                self.push_pole_vector(cp.pole[e], &v);
            }
        }
    }

    /// The eigenpairs of the coupled entries (module docs: Schur guesses, Newton polish,
    /// closed-form vectors).
    fn coupled_modes(&mut self, cp: &Coupled) -> Result<(), SimError> {
        let ne = cp.ne;
        let md = cp.md;
        // Balanced first-order matrix (one coordinate per entry, mass 1, weight w_e):
        // [[0, W], [−P W, −P Z]], P = I − ĝĝᵀ, gₑ = √(m_d wₑ).
        let mut g = [0.0; MAX_BEAM_MODES];
        let mut gg = 0.0;
        for (gj, w) in g.iter_mut().zip(&cp.w).take(ne) {
            *gj = (md * w).sqrt();
            gg += *gj * *gj;
        }
        let scale2 = 1.0 / (1.0 + gg);
        let a = DMatrix::<f64>::from_fn(2 * ne, 2 * ne, |r, c| match (r < ne, c < ne) {
            (true, true) => 0.0,
            (true, false) => {
                if c - ne == r {
                    cp.om[r]
                } else {
                    0.0
                }
            }
            (false, col_pos) => {
                let (i, j) = (r - ne, if col_pos { c } else { c - ne });
                let pij = if i == j { 1.0 } else { 0.0 } - g[i] * g[j] * scale2;
                if col_pos {
                    -pij * cp.om[j]
                } else {
                    -pij * cp.z[j]
                }
            }
        });
        if !a.iter().all(|v| v.is_finite()) {
            return Err(not_finite(f64::NAN));
        }
        let schur = nalgebra::Schur::try_new(a, f64::EPSILON, 100_000 * ne).ok_or(
            SimError::Param(ParamError::NonFiniteResult {
                quantity: "constrained modes (Schur iteration of the 2N×2N stick/contact matrix)",
                value: f64::NAN,
                cause: "the eigenvalue iteration did not converge; modal data outside a sane range",
            }),
        )?;
        let guesses = schur.complex_eigenvalues();
        let mut roots = [(Complex64::new(0.0, 0.0), Complex64::new(0.0, 0.0)); MAX_TERMS];
        let mut nr = 0;
        for gs in guesses.iter() {
            let Some((u, delta)) = cp.polish(*gs) else {
                return Err(not_finite(gs.norm()));
            };
            let s = u + delta;
            let known = roots[..nr]
                .iter()
                .any(|&(u2, d2)| ((u2 - u) + (d2 - delta)).norm() <= SAME_ROOT_REL * s.norm());
            if !known {
                if nr == ne {
                    return Err(repeated(f64::NAN));
                }
                roots[nr] = (u, delta);
                nr += 1;
            }
        }
        if nr != ne {
            // Two guesses polished to one root: two roots closer than rounding can separate.
            return Err(repeated(0.0));
        }
        for &(u, delta) in &roots[..nr] {
            let y = cp.entry_values(u, delta);
            let mut x = [Complex64::new(0.0, 0.0); MAX_BEAM_MODES];
            let mut big: f64 = 0.0;
            for (j, xj) in x.iter_mut().enumerate().take(self.n) {
                let e = cp.entry_of[j];
                if e != usize::MAX {
                    *xj = y[e] * (self.rows[0][j] / self.mass[j]);
                    big = big.max(xj.norm());
                }
            }
            for xj in x.iter_mut() {
                *xj /= big;
            }
            self.push_pair(u + delta, &x);
        }
        Ok(())
    }

    /// `q_s = K⁻¹φ_f F_s`; `X` from `(K − Ω²M_c + iΩC)X = φ_f F0` (LU, one refinement step).
    fn particular(&mut self, sys: &ModalSystem) -> Result<(), SimError> {
        let n = self.n;
        let (fs, f0) = (sys.forcing.static_force_n, sys.forcing.amplitude_n);
        let phi_f = self.rows[1];
        let phi_d = self.rows[0];
        for ((q, p), k) in self
            .q_static
            .iter_mut()
            .zip(&phi_f)
            .zip(&self.stiffness)
            .take(n)
        {
            *q = p * fs / k;
        }
        // A body force on the held ball (`m_d g_s` at the cavity) is a second static load:
        // `q_s += K⁻¹φ_d m_d g_s` (nothing added without one: those runs stay bit-identical).
        let gs = sys.damper.map_or(0.0, |d| d.gravity_along_gap_m_s2);
        if gs != 0.0 {
            let load = self.ball_mass_kg * gs;
            for ((q, p), k) in self
                .q_static
                .iter_mut()
                .zip(&phi_d)
                .zip(&self.stiffness)
                .take(n)
            {
                *q += p * load / k;
            }
        }
        if f0 == 0.0 {
            return Ok(());
        }
        let om = self.omega_rad_s;
        let md = self.ball_mass_kg;
        let q = DMatrix::<Complex64>::from_fn(n, n, |i, j| {
            let mut v = Complex64::new(-om * om * md * phi_d[i] * phi_d[j], 0.0);
            if i == j {
                v += Complex64::new(
                    self.stiffness[j] - om * om * self.mass[j],
                    om * self.damping[j],
                );
            }
            v
        });
        let rhs =
            nalgebra::DVector::<Complex64>::from_fn(n, |i, _| Complex64::new(phi_f[i] * f0, 0.0));
        let lu = q.clone().lu();
        let resonance = SimError::UndampedResonance { omega_rad_s: om };
        // A pivot at rounding level of the largest entry: Ω is an undamped constrained natural
        // frequency (a damped bar's smallest pivot is ≥ 2ζk₁, many orders above this).
        let big = (0..n).map(|i| q[(i, i)].norm()).fold(0.0, f64::max);
        let u = lu.u();
        if (0..n).any(|i| u[(i, i)].norm() <= 1e-13 * big) {
            return Err(resonance);
        }
        let mut x = lu.solve(&rhs).ok_or(resonance.clone())?;
        let r = &rhs - &q * &x;
        if let Some(dx) = lu.solve(&r) {
            x += dx;
        }
        if !x.iter().all(|v| v.re.is_finite() && v.im.is_finite()) {
            return Err(resonance);
        }
        for j in 0..n {
            self.q_harm[j] = x[j];
        }
        Ok(())
    }

    fn check_finite(&self) -> Result<(), SimError> {
        let n = self.n;
        let t = self.n_terms;
        let bad = |z: &Complex64| !(z.re.is_finite() && z.im.is_finite());
        let first_bad = self.eig[..t]
            .iter()
            .chain(self.w_q[..t].iter().flat_map(|r| &r[..n]))
            .chain(self.w_dq[..t].iter().flat_map(|r| &r[..n]))
            .chain(self.vecs[..t].iter().flat_map(|r| &r[..n]))
            .chain(&self.q_harm[..n])
            .find(|z| bad(z));
        if let Some(z) = first_bad {
            return Err(not_finite(z.re + z.im));
        }
        if let Some(v) = self.q_static[..n].iter().find(|v| !v.is_finite()) {
            return Err(not_finite(*v));
        }
        Ok(())
    }

    /// Number of modes `N`.
    pub fn n_modes(&self) -> usize {
        self.n
    }

    /// Ball mass `m_d`.
    pub fn ball_mass_kg(&self) -> f64 {
        self.ball_mass_kg
    }

    /// Forcing frequency `Ω`.
    pub fn forcing_omega_rad_s(&self) -> f64 {
        self.omega_rad_s
    }

    /// The constrained eigenvalues, one per conjugate pair (`Im ≥ 0`): `−α + iω_d`.
    pub fn eigenvalues(&self) -> &[Complex64] {
        &self.eig[..self.n_terms]
    }

    /// Smallest conditioning `ρₖ` of the constrained modes (1 for lone modes; module docs).
    pub fn min_conditioning(&self) -> f64 {
        self.min_conditioning
    }

    /// The modal damping `cₙ = 2ζₙ√(kₙmₙ)` and stiffness `kₙ` used (fixed rows, unused 0).
    pub fn damping_and_stiffness(&self) -> ([f64; MAX_BEAM_MODES], [f64; MAX_BEAM_MODES]) {
        (self.damping, self.stiffness)
    }

    /// Closed-form coefficients of the segment starting at `t0` from `(q0, q̇0)`: `O(N²)`, no
    /// allocation. Entries beyond `N` are ignored; the state is the solver's own (finite, not
    /// re-checked on this hot path).
    pub fn segment(
        &self,
        t0_s: f64,
        q0: &[f64; MAX_BEAM_MODES],
        dq0: &[f64; MAX_BEAM_MODES],
    ) -> ConstrainedMotion<'_> {
        let n = self.n;
        let (sn, cs) = (self.omega_rad_s * t0_s).sin_cos();
        let rot = Complex64::new(cs, sn);
        let mut y0 = [0.0; MAX_BEAM_MODES];
        let mut dy0 = [0.0; MAX_BEAM_MODES];
        for j in 0..n {
            let h = self.q_harm[j] * rot;
            y0[j] = q0[j] - self.q_static[j] - h.im;
            dy0[j] = dq0[j] - self.omega_rad_s * h.re;
        }
        let mut coef = [Complex64::new(0.0, 0.0); MAX_TERMS];
        for (t, c) in coef.iter_mut().enumerate().take(self.n_terms) {
            *c = cdot(&self.w_q[t][..n], &y0[..n]) + cdot(&self.w_dq[t][..n], &dy0[..n]);
        }
        ConstrainedMotion {
            modes: self,
            t0_s,
            rot,
            coef,
        }
    }
}

fn repeated(rho: f64) -> SimError {
    SimError::Param(ParamError::Limit {
        field: "conditioning of the constrained modes (stick / wall contact), min over modes",
        value: rho,
        min: MIN_MODE_CONDITIONING,
        max: 1.0,
        why: "two constrained eigenvalues (nearly) coincide: a nearly defective mode, or two \
              modes of equal frequency and damping both moving the cavity; the closed form \
              would lose more than 6 digits",
    })
}

/// The motion of one segment with the ball held (module docs): closed forms in local time.
#[derive(Debug, Clone, Copy)]
pub struct ConstrainedMotion<'a> {
    modes: &'a ConstrainedModes,
    t0_s: f64,
    rot: Complex64,
    coef: [Complex64; MAX_TERMS],
}

impl ConstrainedMotion<'_> {
    /// Segment start time.
    pub fn t0_s(&self) -> f64 {
        self.t0_s
    }

    fn build(&self, constant: f64, harm: Complex64, proj: impl Fn(usize) -> Complex64) -> TermSum {
        let cm = self.modes;
        let y = harm * self.rot;
        let mut out = TermSum::zero(cm.omega_rad_s);
        out.constant = constant;
        out.cos_omega = y.im;
        out.sin_omega = y.re;
        for t in 0..cm.n_terms {
            let z = self.coef[t] * proj(t);
            let s = cm.eig[t];
            out.decays[t] = if cm.paired[t] {
                [-s.re, s.im, 2.0 * z.re, -2.0 * z.im]
            } else {
                [-s.re, 0.0, z.re, 0.0]
            };
        }
        out.n_decays = cm.n_terms;
        out
    }

    /// The closed form of `r·q(τ)` for any row `r` (shapes at a point, or a unit vector for one
    /// coordinate): `O(N²)`.
    pub fn sum(&self, r: &[f64; MAX_BEAM_MODES]) -> TermSum {
        let cm = self.modes;
        let n = cm.n;
        let constant = r[..n].iter().zip(&cm.q_static).map(|(a, b)| a * b).sum();
        let harm = cdot(&cm.q_harm[..n], &r[..n]);
        self.build(constant, harm, |t| cdot(&cm.vecs[t][..n], &r[..n]))
    }

    /// The closed form of `u(x_p, τ) = φ(x_p)·q(τ)` at one of the system's points: `O(N)`.
    pub fn sum_at(&self, p: Point) -> TermSum {
        let cm = self.modes;
        let i = point_index(p);
        self.build(cm.static_at_point[i], cm.harm_at_point[i], |t| {
            cm.at_point[i][t]
        })
    }

    /// The closed form of one modal coordinate `q_j(τ)`: `O(N)`.
    pub fn sum_coordinate(&self, j: usize) -> TermSum {
        let cm = self.modes;
        if j >= cm.n {
            return TermSum::zero(cm.omega_rad_s);
        }
        self.build(cm.q_static[j], cm.q_harm[j], |t| cm.vecs[t][j])
    }

    /// The holding (contact) force `f_c(τ) = m_d φ_dᵀq̈(τ)`: the force the bar exerts ON the ball,
    /// positive in the `+u` direction. `O(N)`: the second derivative of [`Self::sum_at`] at the
    /// cavity, scaled by `m_d`, built in one pass (no constant part).
    pub fn holding_force(&self) -> TermSum {
        let cm = self.modes;
        let (md, om) = (cm.ball_mass_kg, cm.omega_rad_s);
        self.build(0.0, cm.harm_at_point[0] * (-om * om * md), |t| {
            let s = cm.eig[t];
            cm.at_point[0][t] * (s * s * md)
        })
    }

    /// Modal coordinates and velocities at local time `τ`: `O(N²)`.
    pub fn state_at(&self, tau_s: f64) -> ([f64; MAX_BEAM_MODES], [f64; MAX_BEAM_MODES]) {
        let cm = self.modes;
        let n = cm.n;
        let om = cm.omega_rad_s;
        let (sh, ch) = (om * tau_s).sin_cos();
        let rot = self.rot * Complex64::new(ch, sh);
        let mut q = [0.0; MAX_BEAM_MODES];
        let mut dq = [0.0; MAX_BEAM_MODES];
        for j in 0..n {
            let h = cm.q_harm[j] * rot;
            q[j] = cm.q_static[j] + h.im;
            dq[j] = om * h.re;
        }
        for t in 0..cm.n_terms {
            let s = cm.eig[t];
            let e = self.coef[t] * (s * tau_s).exp();
            let k = if cm.paired[t] { 2.0 } else { 1.0 };
            for j in 0..n {
                let z = e * cm.vecs[t][j];
                q[j] += k * z.re;
                dq[j] += k * (z * s).re;
            }
        }
        (q, dq)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::{FrictionModel, System};

    fn one_mode() -> ModalSystem {
        ModalSystem::from_lumped(&System::paper_damped(1e-4, FrictionModel::Coulomb, 1.0)).unwrap()
    }

    /// `deriv` against central differences of `value` (h = 1e-7 s; error (ωh)²/6 ≈ 1e-9).
    #[test]
    fn deriv_is_the_time_derivative() {
        let mut t = TermSum::zero(3000.0);
        t.constant = 0.3;
        t.cos_omega = 1.5;
        t.sin_omega = -0.7;
        t.decays[0] = [50.0, 2000.0, 0.4, -0.9];
        t.decays[1] = [120.0, 0.0, -0.2, 0.0];
        t.n_decays = 2;
        let d = t.deriv();
        let h = 1e-7;
        for i in 0..50 {
            let tau = i as f64 * 1e-4;
            let fd = (t.value(tau + h) - t.value(tau - h)) / (2.0 * h);
            assert!(
                (d.value(tau) - fd).abs() <= 1e-6 * 6000.0,
                "{tau}: {} vs {fd}",
                d.value(tau)
            );
        }
        assert_eq!(d.constant.to_bits(), 0.0f64.to_bits());
        let (a, b) = (t.scaled(2.0).value(1e-3), 2.0 * t.value(1e-3));
        assert!((a - b).abs() <= 1e-15 * b.abs(), "{a} vs {b}");
    }

    /// The representatives are N pairs with `Im > 0`; the lone mode is well conditioned.
    #[test]
    fn one_mode_has_one_well_conditioned_pair() {
        let cm = ConstrainedModes::new(&one_mode()).unwrap();
        assert_eq!(cm.eigenvalues().len(), 1);
        assert!(cm.eigenvalues()[0].im > 0.0);
        assert!(cm.min_conditioning() > 0.99, "{}", cm.min_conditioning());
    }
}
