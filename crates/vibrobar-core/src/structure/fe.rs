//! Finite elements of a clamped–free Euler–Bernoulli bar: Hermite cubic elements (deflection and
//! slope at each node), consistent mass, a section constant per element plus an optional local
//! loss integrated exactly ([`HoleLoss`]), a tip mass with rotary inertia; reduced to its first modes by a dense symmetric eigensolver.
//!
//! **Why nalgebra, and why the inverted form.** The models here have at most
//! `2·MAX_FE_ELEMENTS` degrees of freedom and we need all of the lowest modes once per run:
//! nalgebra's `Cholesky` and `SymmetricEigen` (Householder tridiagonalisation and implicit QR) do
//! exactly that, are well kept and compile quickly with no default features; faer's generalized
//! eigensolver would do too but costs several times the build. A symmetric QR eigensolver gets each
//! eigenvalue to an *absolute* error of about `ε·‖A‖`. In the textbook form `L_M⁻¹ K L_M⁻ᵀ`
//! (`M = L_M L_Mᵀ`) the modes we keep are the *smallest* eigenvalues `ωₙ²`, far below
//! `‖A‖ ≈ ω_max²` (the mesh's highest mode), and would lose `log₁₀(ω_max²/ω₁²)` digits. So we
//! factor the stiffness instead, `K = L Lᵀ` (positive definite: the clamp removes the rigid-body
//! motion), and solve `L⁻¹ M L⁻ᵀ y = μ y` with `μ = 1/ω²`: the modes we keep are now the
//! *largest* eigenvalues and keep full relative precision. Shapes are `φ = L⁻ᵀ y`. Measured on
//! a uniform bar, error of `ω₁` at 128 / 256 / 500 elements: textbook form −1.3e-7 / 5.6e-6 /
//! 1.0e-4, this form −1.1e-9 / −1.8e-8 / −1.3e-7 (what remains is the conditioning of the
//! assembled `K`, `~ε·n⁴`: the reason the mesh rule refines no further than it needs).
//!
//! The element matrices (length `h`, `EI`, `ρA`; dofs `w₁, θ₁, w₂, θ₂`):
//! `K_e = EI/h³ [12, 6h, −12, 6h; 6h, 4h², −6h, 2h²; −12, −6h, 12, −6h; 6h, 2h², −6h, 4h²]`,
//! `M_e = ρAh/420 [156, 22h, 54, −13h; 22h, 4h², 13h, −3h²; 54, 13h, 156, −22h; −13h, −3h², −22h, 4h²]`.
//! Their eigenvalues converge as `h⁴` (relative error of `ωₙ` about `(βₙh)⁴/1440`, measured
//! in the tests).

use crate::error::ParamError;
use nalgebra::{DMatrix, DVector};

/// A local loss of section, `EI(x) = EI_e − ei_per_c·c(x)` and `ρA(x) = ρA_e − rho_a_per_c·c(x)`
/// with `c(x) = √(r² − (x − x₀)²)` for `|x − x₀| ≤ r` (the transverse hole of
/// [`super::beam`]). Integrated exactly into the matrices of the elements inside it (the mesh puts
/// nodes at `x₀ ± r`): in `x = x₀ + r sin θ` the integrands `r² cos²θ · polynomial` are smooth,
/// and composite Simpson with [`HOLE_QUADRATURE_INTERVALS`] intervals is exact to ~1e-12.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HoleLoss {
    /// Centre `x₀`, from the clamp.
    pub centre_m: f64,
    /// Half-width `r` along the bar.
    pub radius_m: f64,
    /// Bending stiffness lost per unit `c`, N·m (`E·4/3·(ℓ/2)³` for the hole).
    pub ei_per_c: f64,
    /// Mass per length lost per unit `c`, kg/m² (`ρ·2ℓ` for the hole).
    pub rho_a_per_c: f64,
}

/// Simpson intervals of the hole integrals (per element).
pub const HOLE_QUADRATURE_INTERVALS: usize = 128;

impl HoleLoss {
    /// `∫_a^b c(x) g(x) dx` over an element inside the hole.
    fn integrate(&self, a: f64, b: f64, g: impl Fn(f64) -> f64) -> f64 {
        let r = self.radius_m;
        let th = |x: f64| ((x - self.centre_m) / r).clamp(-1.0, 1.0).asin();
        let (t0, t1) = (th(a), th(b));
        let f = |t: f64| {
            let c = r * t.cos();
            c * c * g(self.centre_m + r * t.sin())
        };
        let n = HOLE_QUADRATURE_INTERVALS;
        let dt = (t1 - t0) / n as f64;
        let mut acc = f(t0) + f(t1);
        for k in 1..n {
            acc += if k % 2 == 1 { 4.0 } else { 2.0 } * f(t0 + k as f64 * dt);
        }
        acc * dt / 3.0
    }

    /// True for an element `[a, b]` inside the hole (to rounding of the node positions).
    fn covers(&self, a: f64, b: f64) -> bool {
        let tol = 1e-9 * self.radius_m;
        a >= self.centre_m - self.radius_m - tol && b <= self.centre_m + self.radius_m + tol
    }
}

/// Hermite cubics on `[a, a + h]` at `x`: values `N` and second derivatives `N''` (dofs
/// `w₁, θ₁, w₂, θ₂`).
fn hermite(a: f64, h: f64, x: f64) -> ([f64; 4], [f64; 4]) {
    let s = (x - a) / h;
    let (s2, s3) = (s * s, s * s * s);
    (
        [
            1.0 - 3.0 * s2 + 2.0 * s3,
            h * (s - 2.0 * s2 + s3),
            3.0 * s2 - 2.0 * s3,
            h * (s3 - s2),
        ],
        [
            (-6.0 + 12.0 * s) / (h * h),
            (-4.0 + 6.0 * s) / h,
            (6.0 - 12.0 * s) / (h * h),
            (6.0 * s - 2.0) / h,
        ],
    )
}

/// A clamped (at `nodes[0] = 0`) – free (at the last node) bar cut into elements.
#[derive(Debug, Clone, PartialEq)]
pub struct Mesh {
    /// Node positions from the clamp, increasing, first 0, last `L`.
    pub nodes_m: Vec<f64>,
    /// Bending stiffness `EI` of each element (one fewer than nodes), N·m².
    pub ei_n_m2: Vec<f64>,
    /// Mass per length `ρA` of each element, kg/m.
    pub rho_a_kg_m: Vec<f64>,
    /// Point mass at the tip, kg.
    pub tip_mass_kg: f64,
    /// Rotary inertia at the tip, kg·m².
    pub tip_inertia_kg_m2: f64,
    /// Optional local loss of section, on top of the elements' `EI`, `ρA`.
    pub hole: Option<HoleLoss>,
}

/// Modes of a [`Mesh`], shapes normalised to 1 at the tip.
#[derive(Debug, Clone, PartialEq)]
pub struct FeModes {
    /// `ωₙ`, increasing.
    pub omega_rad_s: Vec<f64>,
    /// `φₙᵀ M φₙ` with `φₙ(L) = 1`.
    pub modal_mass_kg: Vec<f64>,
    /// Nodal deflections of each mode (node 0, the clamp, included as 0), tip = 1.
    pub deflection: Vec<Vec<f64>>,
    /// Nodal slopes of each mode.
    pub slope: Vec<Vec<f64>>,
    /// Static tip deflection per unit tip force of the whole model, m/N.
    pub static_tip_compliance_m_per_n: f64,
}

impl Mesh {
    /// Number of elements.
    pub fn elements(&self) -> usize {
        self.nodes_m.len() - 1
    }

    /// Global stiffness and mass matrices over the free dofs (`w, θ` of nodes 1..).
    pub fn matrices(&self) -> (DMatrix<f64>, DMatrix<f64>) {
        let ne = self.elements();
        let n = 2 * ne;
        let mut k = DMatrix::zeros(n, n);
        let mut m = DMatrix::zeros(n, n);
        for e in 0..ne {
            let h = self.nodes_m[e + 1] - self.nodes_m[e];
            let (ei, ra) = (self.ei_n_m2[e], self.rho_a_kg_m[e]);
            let ke = [
                [12.0, 6.0 * h, -12.0, 6.0 * h],
                [6.0 * h, 4.0 * h * h, -6.0 * h, 2.0 * h * h],
                [-12.0, -6.0 * h, 12.0, -6.0 * h],
                [6.0 * h, 2.0 * h * h, -6.0 * h, 4.0 * h * h],
            ];
            let me = [
                [156.0, 22.0 * h, 54.0, -13.0 * h],
                [22.0 * h, 4.0 * h * h, 13.0 * h, -3.0 * h * h],
                [54.0, 13.0 * h, 156.0, -22.0 * h],
                [-13.0 * h, -3.0 * h * h, -22.0 * h, 4.0 * h * h],
            ];
            let (kc, mc) = (ei / (h * h * h), ra * h / 420.0);
            let (mut ke, mut me) = (ke.map(|r| r.map(|v| kc * v)), me.map(|r| r.map(|v| mc * v)));
            let a0 = self.nodes_m[e];
            if let Some(hole) = self.hole.filter(|o| o.covers(a0, a0 + h)) {
                for a in 0..4 {
                    for b in 0..4 {
                        ke[a][b] -= hole.ei_per_c
                            * hole.integrate(a0, a0 + h, |x| {
                                let d2 = hermite(a0, h, x).1;
                                d2[a] * d2[b]
                            });
                        me[a][b] -= hole.rho_a_per_c
                            * hole.integrate(a0, a0 + h, |x| {
                                let n = hermite(a0, h, x).0;
                                n[a] * n[b]
                            });
                    }
                }
            }
            // Global dof of local dof a: node e's dofs are 2(e−1), 2(e−1)+1; node 0 is clamped.
            let dof = |a: usize| (2 * e + a).checked_sub(2);
            for a in 0..4 {
                let Some(i) = dof(a) else { continue };
                for b in 0..4 {
                    let Some(j) = dof(b) else { continue };
                    k[(i, j)] += ke[a][b];
                    m[(i, j)] += me[a][b];
                }
            }
        }
        m[(n - 2, n - 2)] += self.tip_mass_kg;
        m[(n - 1, n - 1)] += self.tip_inertia_kg_m2;
        (k, m)
    }

    /// The first `n_modes` modes (see the module docs for the method).
    pub fn modes(&self, n_modes: usize) -> Result<FeModes, ParamError> {
        let (k, m) = self.matrices();
        let n = k.nrows();
        let not_spd = || ParamError::NonFiniteResult {
            quantity: "finite-element stiffness matrix (Cholesky)",
            value: f64::NAN,
            cause: "the bar's section or mesh is degenerate (EI ≤ 0 or elements of zero length)",
        };
        let chol = nalgebra::Cholesky::new(k).ok_or_else(not_spd)?;
        let l = chol.l();
        // A = L⁻¹ M L⁻ᵀ, symmetrised against rounding.
        let x = l.solve_lower_triangular(&m).ok_or_else(not_spd)?; // L⁻¹ M
        let mut a = l
            .solve_lower_triangular(&x.transpose())
            .ok_or_else(not_spd)?; // L⁻¹ (L⁻¹M)ᵀ
        for i in 0..n {
            for j in 0..i {
                let s = 0.5 * (a[(i, j)] + a[(j, i)]);
                a[(i, j)] = s;
                a[(j, i)] = s;
            }
        }
        let eig = nalgebra::SymmetricEigen::new(a);
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&i, &j| eig.eigenvalues[j].total_cmp(&eig.eigenvalues[i]));
        let lt = l.transpose();
        let mut out = FeModes {
            omega_rad_s: Vec::with_capacity(n_modes),
            modal_mass_kg: Vec::with_capacity(n_modes),
            deflection: Vec::with_capacity(n_modes),
            slope: Vec::with_capacity(n_modes),
            static_tip_compliance_m_per_n: 0.0,
        };
        for &i in order.iter().take(n_modes.min(n)) {
            let mu = eig.eigenvalues[i];
            let y: DVector<f64> = eig.eigenvectors.column(i).into_owned();
            let phi = lt.solve_upper_triangular(&y).ok_or_else(not_spd)?;
            let tip = phi[n - 2];
            let scale = phi.amax();
            let normalisable = mu > 0.0 && tip.abs() > 1e-9 * scale;
            if !normalisable {
                return Err(ParamError::NonFiniteResult {
                    quantity: "finite-element mode normalised to 1 at the tip",
                    value: tip,
                    cause: "a mode with (almost) no tip motion; the tip normalisation fails",
                });
            }
            let phi = phi / tip;
            let mm = (phi.transpose() * &m * &phi)[(0, 0)];
            out.omega_rad_s.push(1.0 / mu.sqrt());
            out.modal_mass_kg.push(mm);
            let mut w = vec![0.0];
            let mut th = vec![0.0];
            for node in 0..n / 2 {
                w.push(phi[2 * node]);
                th.push(phi[2 * node + 1]);
            }
            out.deflection.push(w);
            out.slope.push(th);
        }
        let mut e_tip = DVector::zeros(n);
        e_tip[n - 2] = 1.0;
        out.static_tip_compliance_m_per_n = chol.solve(&e_tip)[n - 2];
        Ok(out)
    }

    /// Mass of the bar, `∫ρA dx` (tip mass excluded), as the matrices integrate it.
    pub fn mass_kg(&self) -> f64 {
        (0..self.elements())
            .map(|e| {
                let (a, b) = (self.nodes_m[e], self.nodes_m[e + 1]);
                let lost = self
                    .hole
                    .filter(|o| o.covers(a, b))
                    .map_or(0.0, |o| o.rho_a_per_c * o.integrate(a, b, |_| 1.0));
                self.rho_a_kg_m[e] * (b - a) - lost
            })
            .sum()
    }

    /// Value at `x` of a field given by nodal deflections and slopes (Hermite interpolation;
    /// exact at nodes).
    pub fn interpolate(&self, w: &[f64], th: &[f64], x: f64) -> f64 {
        let ne = self.elements();
        let e = match self.nodes_m.partition_point(|&p| p <= x) {
            0 => 0,
            k => (k - 1).min(ne - 1),
        };
        let (a, b) = (self.nodes_m[e], self.nodes_m[e + 1]);
        let n = hermite(a, b - a, x.clamp(a, b)).0;
        n[0] * w[e] + n[1] * th[e] + n[2] * w[e + 1] + n[3] * th[e + 1]
    }
}
