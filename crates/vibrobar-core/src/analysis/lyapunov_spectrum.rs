//! The whole Lyapunov spectrum of the lumped bar (issue #11, item 5): QR re-orthonormalisation
//! (Benettin et al. 1980; Müller 1995 for the saltation at events) of the variational flow of
//! [`super::variational`].
//!
//! An orthonormal frame `Q` (4×4, in the scaled coordinates `(u/s_u, u̇/s_u̇, w/s_w, ẇ/s_ẇ)` of
//! [`StateScales`]) is carried through every segment's transition matrix and every event's
//! saltation matrix, and re-orthonormalised after each (`m Q = Q' R`, Gram–Schmidt). The
//! exponents are `λᵢ = Σ ln Rᵢᵢ / T` over the window. Each block of the window is one solver
//! run; the spread of the block means gives the uncertainty.
//!
//! * **Volume.** `Σ λᵢ = ln|det J| / T`. For the frictionless lumped bar in free flight
//!   `det Φ = e^{−(C/M)τ}` and each impact's saltation matrix has `det S = e²`, so
//!   `Σ λᵢ = −C/M + 2 ln(e) × impacts per second` (shared VALIDATION.md); the estimate checks
//!   it (tests).
//! * **Collapsed directions.** Stick (`ẇ = 0`) and wall contact (`w = ±l_g`, `ẇ = 0`) remove
//!   dimensions: the Jacobian's rank drops, for good. Those exponents are `−∞`; they are
//!   reported as `None` ([`SpectrumResult::exponents_per_s`]) and counted
//!   ([`SpectrumResult::collapsed`]). The count is structural, from what the run went through
//!   (stick or a plastic impact: one, wall contact: two), not a guess from small `Rᵢᵢ`: a
//!   near-grazing impact's large saltation makes a product of maps ill-conditioned without
//!   any loss of rank. The removed directions are the frame's last columns (Gram–Schmidt
//!   puts a column in the span of the earlier ones last); a column that is zero to rounding
//!   is replaced by a unit vector orthogonal to the others so the frame stays orthonormal.
//! * The tangent maps of [`STEPS_PER_QR`] steps are multiplied before each
//!   re-orthonormalisation (the exponents do not depend on how often it happens, as long as
//!   no column leaves the range of `f64`).
//! * **Hertz law.** A compliant contact phase removes no dimension; its tangent map (one step,
//!   [`super::variational`]) has `det = exp(∫ tr A dt) · (1 + cᵀW⁻¹ζ)` (friction events aside):
//!   `Σ λᵢ` is the time average of the trace (`−C/M`, plus `−P_δ̇ (1/M + 1/m_d)` in contact)
//!   plus [`SpectrumResult::approach_memory_per_s`]. A block that ends inside a contact hands
//!   its state to the next block's run, which restarts the contact at `δ = 0` (the state is
//!   put back on the wall, as for the restitution law's rounding): a perturbation of the
//!   trajectory of the size of one compression, at most once per block.
//! * Lumped bar (the variational layer's scope).

use super::lyapunov::StateScales;
use super::variational::{mat_mul, EventCounts, Mat4, Step, TangentSink, Variational, IDENTITY};
use crate::error::SimError;
use crate::params::{State, System};
use crate::solver::{EventKind, Mode, Solver};

/// Relative size of `Rᵢᵢ` (against the column's norm before orthogonalisation) below which the
/// column is replaced by an orthogonal unit vector (it lies in the span of the earlier ones).
pub const COLLAPSE_REL: f64 = 1e-12;

/// Settings of a spectrum.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpectrumParams {
    /// Discarded time before the window (from `init.t_s`).
    pub transient_s: f64,
    /// Length of the window over which the exponents are averaged.
    pub duration_s: f64,
    /// Blocks of the window, one run each (at least 2): the uncertainty.
    pub blocks: usize,
    /// Scales; `None` uses [`StateScales::for_system`].
    pub scales: Option<StateScales>,
}

impl SpectrumParams {
    /// `periods` forcing periods after `transient_s`, 10 blocks.
    pub fn periods(sys: &System, transient_s: f64, periods: f64) -> Self {
        SpectrumParams {
            transient_s,
            duration_s: periods * sys.forcing_period_s(),
            blocks: 10,
            scales: None,
        }
    }
}

/// The spectrum.
#[derive(Debug, Clone, PartialEq)]
pub struct SpectrumResult {
    /// `λ₁ ≥ … ≥ λ₄` in 1/s (in the Gram–Schmidt order, which sorts them in the limit); `None`
    /// for a collapsed direction (`−∞`: stick or wall contact removed it).
    pub exponents_per_s: Vec<Option<f64>>,
    /// Standard error of each exponent from the spread of the block means (`None` where
    /// collapsed).
    pub std_error_per_s: Vec<Option<f64>>,
    /// Number of collapsed directions.
    pub collapsed: usize,
    /// Sum of the finite exponents.
    pub sum_per_s: f64,
    /// Impacts per second over the window (restitution and plastic).
    pub impacts_per_s: f64,
    /// Events the variational flow went through.
    pub events: EventCounts,
    /// Under the hertz law, the part of `sum_per_s` that is the law's memory of the approach
    /// speed (`Σ ln|1 + cᵀW⁻¹ζ|` per second, [`super::variational`] "Hertz contact phases"): the
    /// rest is the time average of the trace of the vector field's Jacobian. 0 otherwise.
    pub approach_memory_per_s: f64,
    /// The window, s.
    pub duration_s: f64,
}

/// The QR sink: the frame, the log sums of the current block, the collapses.
struct QrSink {
    /// `T` (public `(u, u̇, v, v̇)` → scaled `(u, u̇, w, ẇ)`) and its inverse.
    t: Mat4,
    t_inv: Mat4,
    q: Mat4,
    logs: [f64; 4],
    collapsed: [bool; 4],
    impacts: u64,
    /// The product of the tangent maps since the last re-orthonormalisation (public
    /// coordinates) and how many.
    product: Mat4,
    steps: usize,
    /// Directions removed so far (structurally: 1 by stick or a plastic impact that lets the
    /// ball go, 2 by wall contact); they are the last columns of the frame.
    deficit: usize,
    /// `e = 0`: every impact is plastic.
    plastic_law: bool,
    /// `hertz` law: a contact segment is a compliant phase (no dimension removed).
    compliant: bool,
}

/// Tangent maps multiplied together between two re-orthonormalisations. Fewer QRs are cheaper,
/// but a near-grazing impact's large saltation makes a longer product ill-conditioned: on the
/// chaotic frictionless 0.1 mm, e = 0.9 point the phase-volume identity holds to 5e-16 with
/// 1 or 2, 1.4e-14 with 4 and only 1.7e-7 with 8 (the spectrum costs about twice the plain run
/// with 2, against ~7× with 1).
pub const STEPS_PER_QR: usize = 2;

impl QrSink {
    fn new(sc: &StateScales, restitution: f64, compliant: bool) -> QrSink {
        let t = [
            [1.0 / sc.u_m, 0.0, 0.0, 0.0],
            [0.0, 1.0 / sc.du_m_s, 0.0, 0.0],
            [-1.0 / sc.w_m, 0.0, 1.0 / sc.w_m, 0.0],
            [0.0, -1.0 / sc.dw_m_s, 0.0, 1.0 / sc.dw_m_s],
        ];
        let t_inv = [
            [sc.u_m, 0.0, 0.0, 0.0],
            [0.0, sc.du_m_s, 0.0, 0.0],
            [sc.u_m, 0.0, sc.w_m, 0.0],
            [0.0, sc.du_m_s, 0.0, sc.dw_m_s],
        ];
        QrSink {
            t,
            t_inv,
            q: IDENTITY,
            logs: [0.0; 4],
            collapsed: [false; 4],
            impacts: 0,
            product: IDENTITY,
            steps: 0,
            deficit: 0,
            plastic_law: restitution == 0.0 && !compliant,
            compliant,
        }
    }

    /// Re-orthonormalise: `Q ← qr(T·product·T⁻¹·Q)`, accumulating `ln Rᵢᵢ`.
    fn flush(&mut self) {
        if self.steps == 0 {
            return;
        }
        let ms = mat_mul(&self.t, &mat_mul(&self.product, &self.t_inv));
        let mut a = mat_mul(&ms, &self.q);
        let r = gram_schmidt(&mut a);
        for (i, &(rii, _)) in r.iter().enumerate() {
            if i >= 4 - self.deficit {
                self.collapsed[i] = true;
            } else if !self.collapsed[i] {
                self.logs[i] += rii.ln();
            }
        }
        self.q = a;
        self.product = IDENTITY;
        self.steps = 0;
    }
}

/// Modified Gram–Schmidt of the columns of `a` in place: `a = Q R`; returns `diag R` and the
/// norms of the columns as they came in (after projection of the earlier ones, before
/// normalisation the norm is `Rᵢᵢ`). A column with `Rᵢᵢ ≤ COLLAPSE_REL·|aᵢ|` is replaced by a
/// unit vector orthogonal to the earlier ones and reported with `Rᵢᵢ = 0`.
// Index loops read as the linear algebra they are.
#[allow(clippy::needless_range_loop)]
fn gram_schmidt(a: &mut Mat4) -> [(f64, f64); 4] {
    let mut out = [(0.0, 0.0); 4];
    for i in 0..4 {
        let norm_in = (0..4).map(|r| a[r][i] * a[r][i]).sum::<f64>().sqrt();
        for j in 0..i {
            let d: f64 = (0..4).map(|r| a[r][i] * a[r][j]).sum();
            for r in 0..4 {
                a[r][i] -= d * a[r][j];
            }
        }
        let mut n = (0..4).map(|r| a[r][i] * a[r][i]).sum::<f64>().sqrt();
        let rii = n;
        if n.is_nan() || n <= COLLAPSE_REL * norm_in {
            // A unit vector orthogonal to the earlier columns: the coordinate axis with the
            // largest remainder.
            let mut best = ([0.0; 4], 0.0);
            for k in 0..4 {
                let mut v = [0.0; 4];
                v[k] = 1.0;
                for j in 0..i {
                    let d = a[k][j];
                    for r in 0..4 {
                        v[r] -= d * a[r][j];
                    }
                }
                let nv = v.iter().map(|x| x * x).sum::<f64>().sqrt();
                if nv > best.1 {
                    best = (v, nv);
                }
            }
            for r in 0..4 {
                a[r][i] = best.0[r];
            }
            n = best.1;
        }
        for r in 0..4 {
            a[r][i] /= n;
        }
        out[i] = (rii, norm_in);
    }
    out
}

impl TangentSink for QrSink {
    fn apply(&mut self, m: &Mat4, step: Step) {
        let removes = match step {
            Step::Event {
                kind: EventKind::Impact { .. },
                plastic,
                ..
            } => {
                self.impacts += 1;
                usize::from(plastic || self.plastic_law)
            }
            Step::Event {
                kind: EventKind::Stick,
                ..
            }
            | Step::Segment {
                mode: Mode::Stick, ..
            } => 1,
            Step::Segment {
                mode: Mode::Contact(_),
                ..
            } if !self.compliant => 2,
            _ => 0,
        };
        self.deficit = self.deficit.max(removes);
        self.product = mat_mul(m, &self.product);
        self.steps += 1;
        if self.steps >= STEPS_PER_QR {
            self.flush();
        }
    }
}

/// The Lyapunov spectrum of `sys` (lumped bar, either contact law) started from `init`, with the
/// exact solver `solver`.
pub fn lyapunov_spectrum(
    sys: &System,
    init: &State,
    solver: &dyn Solver,
    p: &SpectrumParams,
) -> Result<SpectrumResult, SimError> {
    super::variational::require_exact(solver)?;
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
    let sc = p.scales.unwrap_or_else(|| StateScales::for_system(sys));
    for (field, v) in [
        ("scales.u_m", sc.u_m),
        ("scales.du_m_s", sc.du_m_s),
        ("scales.w_m", sc.w_m),
        ("scales.dw_m_s", sc.dw_m_s),
    ] {
        crate::params::positive(field, v)?;
    }
    // Refuses what the variational layer cannot do before any run.
    let e = sys.damper.map_or(1.0, |d| d.restitution);
    let compliant = sys
        .damper
        .is_some_and(|d| d.contact.law == crate::params::ContactLaw::Hertz);
    let mut var = Variational::new(sys, QrSink::new(&sc, e, compliant))?;
    // The public state carries `v = u + w` rounded: a ball on a wall may read an ulp outside it,
    // which the next run's check refuses. Put it back on the wall (as `max_lyapunov` does).
    let lg = sys.damper.map_or(f64::INFINITY, |d| d.half_gap_m());
    let onto_wall = |mut s: State| {
        super::lyapunov::onto_cavity(&mut s, lg);
        s
    };
    let mut x = onto_wall(
        solver
            .run(sys, init, init.t_s + p.transient_s, &mut ())?
            .final_state,
    );
    let t0 = x.t_s;
    let block = p.duration_s / p.blocks as f64;
    let mut block_rates: Vec<[f64; 4]> = Vec::with_capacity(p.blocks);
    for b in 1..=p.blocks {
        let t_end = t0 + b as f64 * block;
        var.sink.logs = [0.0; 4];
        x = onto_wall(solver.run(sys, &x, t_end, &mut var)?.final_state);
        var.finish();
        if let Some(e) = var.failure.take() {
            return Err(e);
        }
        var.sink.flush();
        let dt = t_end - (t0 + (b - 1) as f64 * block);
        block_rates.push(var.sink.logs.map(|l| l / dt));
    }
    let n = block_rates.len() as f64;
    let collapsed = var.sink.collapsed;
    let mut exps = Vec::with_capacity(4);
    let mut errs = Vec::with_capacity(4);
    let mut sum = 0.0;
    for i in 0..4 {
        if collapsed[i] {
            exps.push(None);
            errs.push(None);
            continue;
        }
        let mean = block_rates.iter().map(|r| r[i]).sum::<f64>() / n;
        let var_i = block_rates
            .iter()
            .map(|r| (r[i] - mean).powi(2))
            .sum::<f64>()
            / (n - 1.0);
        if !mean.is_finite() {
            return Err(SimError::NonFinite { t_s: x.t_s });
        }
        sum += mean;
        exps.push(Some(mean));
        errs.push(Some((var_i / n).sqrt()));
    }
    Ok(SpectrumResult {
        exponents_per_s: exps,
        std_error_per_s: errs,
        collapsed: collapsed.iter().filter(|c| **c).count(),
        sum_per_s: sum,
        impacts_per_s: var.sink.impacts as f64 / p.duration_s,
        events: var.counts,
        approach_memory_per_s: var.approach_memory_log / p.duration_s,
        duration_s: p.duration_s,
    })
}
