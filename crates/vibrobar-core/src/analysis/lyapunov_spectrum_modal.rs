//! The whole Lyapunov spectrum of the N-mode bar (`2N + 2` exponents): QR re-orthonormalisation
//! of the modal variational flow ([`super::variational_modal`]), as on the lumped bar
//! ([`super::lyapunov_spectrum`], whose docs say how collapsed directions (stick, wall contact)
//! are counted and reported as `None`).
//!
//! The frame is carried in `(q, q̇, v, v̇)` and re-orthonormalised every two tangent maps by a
//! weighted Gram–Schmidt with weights `1/sᵢ` (`s_u` for every `qₙ`, `ω₁ s_u` for every `q̇ₙ`,
//! `s_u + l_g` and `ω₁(s_u + l_g)` for the ball; [`StateScales::for_system`]): the exponents do
//! not depend on that fixed inner product.
//!
//! **Volume.** In free flight every mode contracts the phase volume by `e^{−(cₙ/mₙ)τ}` (its
//! 2×2 transition matrix has determinant `e^{−2αₙτ}`, `2αₙ = cₙ/mₙ`) and the ball by nothing;
//! each impact's saltation matrix has `det S = e²` ([`super::variational_modal`]). So for the
//! frictionless modal bar without holding phases
//!
//! `Σᵢ λᵢ = −Σₙ cₙ/mₙ + 2 ln(e) × (impacts per second)`,
//!
//! `cₙ/mₙ = 2ζₙωₙ` (the lumped bar's `−C/M + 2 ln(e)·rate` is its one-mode case). The
//! estimate checks it to 1e-9 (`tests/variational_modal.rs`).

use super::lyapunov::StateScales;
use super::lyapunov_spectrum::{SpectrumParams, SpectrumResult};
use super::variational_modal::{ModalVariational, D_MAX};
use crate::error::SimError;
use crate::solver::exact::modal::ModalExact;
use crate::structure::{ModalState, ModalSystem};

/// `Σₙ cₙ/mₙ = Σₙ 2ζₙωₙ`: the free flight's rate of phase-volume contraction, 1/s.
pub fn modal_volume_contraction_per_s(sys: &ModalSystem) -> f64 {
    sys.model
        .modes()
        .iter()
        .map(|m| 2.0 * m.damping_ratio * m.omega_rad_s)
        .sum()
}

/// The Lyapunov spectrum of the modal system `sys` (a ball under the restitution law) from
/// `init`, with [`ModalExact`].
pub fn lyapunov_spectrum_modal(
    sys: &ModalSystem,
    init: &ModalState,
    p: &SpectrumParams,
) -> Result<SpectrumResult, SimError> {
    crate::params::non_negative("transient_s", p.transient_s)?;
    crate::params::positive("duration_s", p.duration_s)?;
    if p.blocks < 2 || p.blocks > crate::limits::MAX_LYAPUNOV_INTERVALS {
        return Err(crate::error::ParamError::OutOfRange {
            field: "blocks",
            value: p.blocks as f64,
            allowed: "[2, 1000000]",
        }
        .into());
    }
    let sc = p
        .scales
        .unwrap_or_else(|| StateScales::for_system(&sys.to_system()));
    for (field, v) in [
        ("scales.u_m", sc.u_m),
        ("scales.du_m_s", sc.du_m_s),
        ("scales.w_m", sc.w_m),
        ("scales.dw_m_s", sc.dw_m_s),
    ] {
        crate::params::positive(field, v)?;
    }
    let n = sys.n_modes();
    let d = 2 * n + 2;
    let mut scale = [0.0; D_MAX];
    for i in 0..n {
        scale[i] = sc.u_m;
        scale[n + i] = sc.du_m_s;
    }
    scale[2 * n] = sc.u_m + sc.w_m;
    scale[2 * n + 1] = sc.du_m_s + sc.dw_m_s;
    // Refuses what the variational layer cannot do before any run.
    let mut var = ModalVariational::new(sys, init)?.with_qr(scale);
    let solver = ModalExact::default();
    let mut x = solver
        .run(sys, init, init.t_s + p.transient_s, &mut ())?
        .final_state;
    let t0 = x.t_s;
    let block = p.duration_s / p.blocks as f64;
    let mut block_rates: Vec<Vec<f64>> = Vec::with_capacity(p.blocks);
    for b in 1..=p.blocks {
        let t_end = t0 + b as f64 * block;
        var.restart_at(&x);
        if let Some(q) = var.qr_state() {
            q.logs = [0.0; D_MAX];
        }
        x = solver.run_modal(sys, &x, t_end, &mut var)?.final_state;
        var.finish();
        var.flush();
        let dt = t_end - (t0 + (b - 1) as f64 * block);
        let q = var.qr_state().expect("set by with_qr");
        block_rates.push(q.logs[..d].iter().map(|l| l / dt).collect());
    }
    let nb = block_rates.len() as f64;
    let (collapsed, impacts) = {
        let q = var.qr_state().expect("set by with_qr");
        (q.collapsed, q.impacts)
    };
    let mut exps = Vec::with_capacity(d);
    let mut errs = Vec::with_capacity(d);
    let mut sum = 0.0;
    for i in 0..d {
        if collapsed[i] {
            exps.push(None);
            errs.push(None);
            continue;
        }
        let mean = block_rates.iter().map(|r| r[i]).sum::<f64>() / nb;
        let var_i = block_rates
            .iter()
            .map(|r| (r[i] - mean).powi(2))
            .sum::<f64>()
            / (nb - 1.0);
        if !mean.is_finite() {
            return Err(SimError::NonFinite { t_s: x.t_s });
        }
        sum += mean;
        exps.push(Some(mean));
        errs.push(Some((var_i / nb).sqrt()));
    }
    Ok(SpectrumResult {
        exponents_per_s: exps,
        std_error_per_s: errs,
        collapsed: collapsed[..d].iter().filter(|c| **c).count(),
        sum_per_s: sum,
        impacts_per_s: impacts as f64 / p.duration_s,
        events: var.counts,
        duration_s: p.duration_s,
        // Restitution law only (the hertz law is refused): no approach-speed memory.
        approach_memory_per_s: 0.0,
    })
}

/// The phase-volume identity of the frictionless bar for a spectrum with `impacts_per_s`:
/// `−C/M + 2 ln(e) × impacts/s` on the lumped bar, `−Σₙ cₙ/mₙ + 2 ln(e) × impacts/s` on a
/// modal bar (module docs); `None` with friction or without a ball. It is the sum of the
/// exponents when nothing collapsed.
pub fn volume_identity_per_s(
    sys: &crate::params::System,
    impacts_per_s: f64,
) -> Result<Option<f64>, SimError> {
    let Some(d) = sys.damper else {
        return Ok(None);
    };
    if sys.friction_level_n() != 0.0 && d.friction != crate::params::FrictionModel::None {
        return Ok(None);
    }
    let contraction = match &sys.bar {
        crate::params::BarModel::Lumped(bar) => bar.damping_n_s_per_m() / bar.mass_kg,
        crate::params::BarModel::Modal(_) => {
            modal_volume_contraction_per_s(&ModalSystem::from_system(sys)?)
        }
    };
    Ok(Some(
        -contraction + 2.0 * d.restitution.ln() * impacts_per_s,
    ))
}
