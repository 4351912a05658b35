//! A bar's exact flow as the orbit analyses see it: one interface ([`Flow`]) that the lumped bar
//! ([`super::Section`], state `(u, u̇, w, ẇ)`, `D = 4`) and the N-mode bar
//! ([`super::modal::ModalSection`], state `(q₁ … q_N, q̇₁ … q̇_N, w, ẇ)`, `D = 2N + 2`) both
//! implement by delegating to their exact solver and the one variational layer
//! ([`crate::analysis::variational`]: its [`lumped`](crate::analysis::variational::lumped) and
//! [`modal`](crate::analysis::variational::modal) bars). Newton's method, the orbit's
//! description ([`super::find_orbit`], [`super::describe`]) and the continuation
//! ([`super::continuation`]) are written once over it.
//!
//! **Coordinates.** A flow's state vector `x` has the bar's coordinates first and the ball's
//! relative `w`, `ẇ` last (index `D − 2`, `D − 1`), so that `|w| ≤ l_g` is a bound on one
//! coordinate whatever the bar. The variational layer works on `(…, v, v̇)`; its Jacobian is
//! taken to the map's coordinates as `T J T⁻¹` with `T: v ↦ w = v − φ_dᵀq` (`φ_d = 1` and
//! `q = u` on the lumped bar).
//!
//! **Jacobians** of the map ([`MapJacobian`]): [`ExactJacobian`] (the variational flow with
//! saltation matrices, one run) or [`FiniteDifference`] (central differences of the exact solver,
//! `2D + 1` runs, one-sided in `w` at a wall), for either bar.

use crate::error::SimError;
use crate::solver::Observer;
use nalgebra::DMatrix;

/// The stroboscopic map of one system: its state at a section time `t0` and `k` forcing cycles
/// later (module docs).
pub trait Flow: Clone + std::fmt::Debug + PartialEq + Send + Sync {
    /// The solver's state (the lumped `State` or the modal `ModalState`).
    type State: Clone + std::fmt::Debug + PartialEq + Send + Sync;

    /// The starting guess as error messages name it, with its coordinates
    /// (`starting guess (u, u̇, w, ẇ)`).
    const START_FIELD: &'static str;

    /// What Newton says when it does not converge (what to try instead).
    const NO_ORBIT: &'static str;

    /// The dimension `D` of `x`.
    fn dim(&self) -> usize;

    /// The section time `t0`.
    fn t0_s(&self) -> f64;

    /// The period `k` in forcing cycles.
    fn periods(&self) -> u32;

    /// The same system's map at section time `t0_s` over `periods` cycles, checked.
    fn at(&self, t0_s: f64, periods: u32) -> Result<Self, SimError>;

    /// The forcing period `T = 2π/Ω`.
    fn forcing_period_s(&self) -> f64;

    /// The map's period `kT`.
    fn period_s(&self) -> f64;

    /// Forcing frequency `Ω`.
    fn omega_rad_s(&self) -> f64;

    /// Half the cavity's clearance `l_g` (infinite without a ball).
    fn half_gap_m(&self) -> f64;

    /// The contact law is compliant (hertz): an excursion past `l_g` is a contact phase.
    fn compliant(&self) -> bool;

    /// The state of `x` at the section time.
    fn state(&self, x: &[f64]) -> Self::State;

    /// `x` of a state.
    fn vector(&self, s: &Self::State) -> Vec<f64>;

    /// `x` with `w` pulled inside the cavity (the state's own `w`, after `v = w + φ_dᵀq` rounds).
    fn clamp(&self, x: &[f64]) -> Vec<f64>;

    /// Scales of the coordinates of `x` (Newton's and the continuation's units).
    fn scales(&self) -> Vec<f64>;

    /// The exact solver's run from `s` to `t_end_s`, reported to `obs`: the final state and the
    /// largest penetration `|w| − l_g` seen.
    fn run(
        &self,
        s: &Self::State,
        t_end_s: f64,
        obs: &mut dyn Observer,
    ) -> Result<(Self::State, f64), SimError>;

    /// `P(x)`.
    fn flow(&self, x: &[f64]) -> Result<Vec<f64>, SimError> {
        let end = self.t0_s() + self.period_s();
        let (s, _) = self.run(&self.state(x), end, &mut ())?;
        Ok(self.vector(&s))
    }

    /// `P(x)` and `DP(x)` from the variational layer, `T J T⁻¹` (module docs).
    fn exact_jacobian(&self, x: &[f64]) -> Result<(Vec<f64>, DMatrix<f64>), SimError>;
}

/// The Jacobian of the stroboscopic map `DP(x)` in the map's coordinates (SI).
pub trait MapJacobian<F: Flow = super::Section>: Send + Sync {
    /// Short name for output files (`finite-difference`, `variational`).
    fn name(&self) -> &'static str;
    /// `P(x)` and `DP(x)`.
    fn map_and_jacobian(&self, sec: &F, x: &[f64]) -> Result<(Vec<f64>, DMatrix<f64>), SimError>;
}

/// Central differences of the exact solver, step `rel_step` in scaled coordinates (one-sided
/// where a central step would leave the cavity).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FiniteDifference {
    /// Step in scaled units (`w/l_g` etc.).
    pub rel_step: f64,
}

impl Default for FiniteDifference {
    /// A step of 1e-6 scaled units: truncation ~1e-12 and rounding ~1e-10 of the entries.
    fn default() -> Self {
        FiniteDifference { rel_step: 1e-6 }
    }
}

impl<F: Flow> MapJacobian<F> for FiniteDifference {
    fn name(&self) -> &'static str {
        "finite-difference"
    }

    fn map_and_jacobian(&self, sec: &F, x: &[f64]) -> Result<(Vec<f64>, DMatrix<f64>), SimError> {
        let d = sec.dim();
        let iw = d - 2;
        let sc = sec.scales();
        let lg = sec.half_gap_m();
        let px = sec.flow(x)?;
        let sub =
            |a: &[f64], b: &[f64]| -> Vec<f64> { a.iter().zip(b).map(|(a, b)| a - b).collect() };
        let mut jac = DMatrix::zeros(d, d);
        for j in 0..d {
            let h = self.rel_step * sc[j];
            let (mut plus, mut minus) = (x.to_vec(), x.to_vec());
            plus[j] += h;
            minus[j] -= h;
            // w stays inside the cavity: one-sided steps at a wall.
            let (col, width) = if j == iw && plus[iw] > lg {
                (sub(&px, &sec.flow(&minus)?), h)
            } else if j == iw && minus[iw] < -lg {
                (sub(&sec.flow(&plus)?, &px), h)
            } else {
                (sub(&sec.flow(&plus)?, &sec.flow(&minus)?), 2.0 * h)
            };
            for i in 0..d {
                jac[(i, j)] = col[i] / width;
            }
        }
        Ok((px, jac))
    }
}

/// The exact Jacobian: the variational flow with saltation matrices, taken to the map's
/// coordinates ([`Flow::exact_jacobian`]). One run per evaluation instead of `2D + 1`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ExactJacobian;

impl<F: Flow> MapJacobian<F> for ExactJacobian {
    fn name(&self) -> &'static str {
        "variational"
    }

    fn map_and_jacobian(&self, sec: &F, x: &[f64]) -> Result<(Vec<f64>, DMatrix<f64>), SimError> {
        sec.exact_jacobian(x)
    }
}

/// `T J T⁻¹` with `T: (q, q̇, v, v̇) → (q, q̇, v − φ_dᵀq, v̇ − φ_dᵀq̇)` for the shape `phi` of the
/// `n` coordinates `q` at the cavity (`n = 1`, `φ_d = 1` on the lumped bar).
pub fn to_relative_coordinates(phi: &[f64], j: &DMatrix<f64>) -> DMatrix<f64> {
    let n = phi.len();
    let d = 2 * n + 2;
    let mut t = DMatrix::identity(d, d);
    let mut ti = DMatrix::identity(d, d);
    for i in 0..n {
        t[(2 * n, i)] = -phi[i];
        t[(2 * n + 1, n + i)] = -phi[i];
        ti[(2 * n, i)] = phi[i];
        ti[(2 * n + 1, n + i)] = phi[i];
    }
    t * j * ti
}
