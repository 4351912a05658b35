//! The whole Lyapunov spectrum of the lumped bar ([`lyapunov_spectrum`], 4 exponents) and of the
//! N-mode bar ([`lyapunov_spectrum_modal`], `2N + 2`): QR re-orthonormalisation (Benettin et al.
//! 1980; Müller 1995 for the saltation at events) of the one variational layer
//! ([`super::variational`]) on either bar (the lumped bar's 4×4 maps, the N-mode bar's columns,
//! [`super::variational::modal`]). Both hand their tangent maps to one QR frame (`Frame`:
//! Gram–Schmidt, `ln Rᵢᵢ`, the collapsed directions) and one block loop (the exponents and
//! their uncertainty).
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
//! * **Hertz law** (either bar). A compliant contact phase removes no dimension; its tangent
//!   map (one step, [`super::variational`]) has `det = exp(∫ tr A dt) · (1 + cᵀW⁻¹ζ)`
//!   (friction events aside):
//!   `Σ λᵢ` is the time average of the trace (`−C/M`, plus `−P_δ̇ (1/M + 1/m_d)` in contact)
//!   plus [`SpectrumResult::approach_memory_per_s`]. A block that ends inside a contact hands
//!   its state to the next block's run, which restarts the contact at `δ = 0` (the state is
//!   put back on the wall, as for the restitution law's rounding): a perturbation of the
//!   trajectory of the size of one compression, at most once per block.
//! * **N-mode bar.** The frame is carried in `(q, q̇, v, v̇)` and re-orthonormalised every two
//!   tangent maps in the coordinates scaled by `s_u` for every `qₙ`, `ω₁ s_u` for every `q̇ₙ`,
//!   `s_u + l_g` and `ω₁(s_u + l_g)` for the ball ([`StateScales::for_system`]): the exponents do
//!   not depend on that fixed inner product.
//! * **Volume of the N-mode bar.** In free flight every mode contracts the phase volume by
//!   `e^{−(cₙ/mₙ)τ}` (its 2×2 transition matrix has determinant `e^{−2αₙτ}`, `2αₙ = cₙ/mₙ`) and
//!   the ball by nothing; each impact's saltation matrix has `det S = e²`
//!   ([`super::variational::modal`]). So for the frictionless modal bar without holding phases
//!
//!   `Σᵢ λᵢ = −Σₙ cₙ/mₙ + 2 ln(e) × (impacts per second)`,
//!
//!   `cₙ/mₙ = 2ζₙωₙ` (the lumped bar's `−C/M + 2 ln(e)·rate` is its one-mode case). The
//!   estimate checks it to 1e-9 (`tests/variational_modal.rs`).

use super::lyapunov::StateScales;
use super::variational::modal::{ModalVariational, D_MAX};
use super::variational::{mat_mul, EventCounts, Mat4, Step, TangentSink, Variational, IDENTITY};
use crate::error::SimError;
use crate::params::{State, System};
use crate::solver::exact::modal::ModalExact;
use crate::solver::{EventKind, Mode, Solver};
use crate::structure::{ModalState, ModalSystem};

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

/// Tangent maps multiplied together between two re-orthonormalisations. Fewer QRs are cheaper,
/// but a near-grazing impact's large saltation makes a longer product ill-conditioned: on the
/// chaotic frictionless 0.1 mm, e = 0.9 point the phase-volume identity holds to 5e-16 with
/// 1 or 2, 1.4e-14 with 4 and only 1.7e-7 with 8 (the spectrum costs about twice the plain run
/// with 2, against ~7× with 1).
pub const STEPS_PER_QR: usize = 2;

/// The QR frame's bookkeeping, either bar: the log sums of the current block, the collapsed
/// directions, the impacts, the tangent maps since the last re-orthonormalisation.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Frame {
    /// `Σ ln Rᵢᵢ` of the current block.
    pub(crate) logs: Vec<f64>,
    /// Collapsed (removed) directions: the last columns.
    pub(crate) collapsed: Vec<bool>,
    /// Directions removed so far (structurally: 1 by stick or a plastic impact that lets the
    /// ball go, 2 by wall contact); they are the last columns of the frame.
    deficit: usize,
    /// Impacts (restitution and plastic).
    pub(crate) impacts: u64,
    /// Tangent maps since the last re-orthonormalisation.
    pub(crate) steps: usize,
    /// `e = 0`: every impact is plastic.
    plastic_law: bool,
    /// `hertz` law: a contact segment is a compliant phase (no dimension removed).
    compliant: bool,
}

impl Frame {
    /// The frame of a `d`-dimensional flow with restitution `restitution`.
    pub(crate) fn new(d: usize, restitution: f64, compliant: bool) -> Frame {
        Frame {
            logs: vec![0.0; d],
            collapsed: vec![false; d],
            deficit: 0,
            impacts: 0,
            steps: 0,
            plastic_law: restitution == 0.0 && !compliant,
            compliant,
        }
    }

    /// Count the tangent map of `step` (the directions it removes, an impact); whether a
    /// re-orthonormalisation is due ([`STEPS_PER_QR`]).
    pub(crate) fn note(&mut self, step: &Step) -> bool {
        let removes = match *step {
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
        self.steps += 1;
        self.steps >= STEPS_PER_QR
    }

    /// Re-orthonormalise the columns `cols` (scaled coordinates) in place, adding `ln Rᵢᵢ` to the
    /// logs of the directions not collapsed.
    pub(crate) fn orthonormalise(&mut self, cols: &mut [Vec<f64>]) {
        let d = cols.len();
        let r = gram_schmidt(cols);
        for (i, &rii) in r.iter().enumerate() {
            if i >= d - self.deficit {
                self.collapsed[i] = true;
            } else if !self.collapsed[i] {
                self.logs[i] += rii.ln();
            }
        }
        self.steps = 0;
    }
}

/// Modified Gram–Schmidt of the columns `a` in place: `a = Q R`; returns `diag R`. A column
/// with `Rᵢᵢ ≤ COLLAPSE_REL·|aᵢ|` (its norm as it came in) is replaced by a unit vector
/// orthogonal to the earlier ones and reported with `Rᵢᵢ = 0`.
// Index loops read as the linear algebra they are.
#[allow(clippy::needless_range_loop)]
fn gram_schmidt(a: &mut [Vec<f64>]) -> Vec<f64> {
    let d = a.len();
    let mut out = vec![0.0; d];
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    for i in 0..d {
        let (done, rest) = a.split_at_mut(i);
        let col = &mut rest[0];
        let norm_in = norm(col);
        for q in done.iter() {
            let dd: f64 = (0..d).map(|r| col[r] * q[r]).sum();
            for r in 0..d {
                col[r] -= dd * q[r];
            }
        }
        let mut n = norm(col);
        let rii = n;
        if n.is_nan() || n <= COLLAPSE_REL * norm_in {
            // A unit vector orthogonal to the earlier columns: the coordinate axis with the
            // largest remainder.
            let mut best = (vec![0.0; d], 0.0);
            for k in 0..d {
                let mut v = vec![0.0; d];
                v[k] = 1.0;
                for q in done.iter() {
                    let dd = q[k];
                    for r in 0..d {
                        v[r] -= dd * q[r];
                    }
                }
                let nv = norm(&v);
                if nv > best.1 {
                    best = (v, nv);
                }
            }
            *col = best.0;
            n = best.1;
        }
        for r in 0..d {
            col[r] /= n;
        }
        out[i] = rii;
    }
    out
}

/// The lumped bar's QR sink: the frame `Q` (scaled coordinates) and the product of the tangent
/// maps since the last re-orthonormalisation (public coordinates).
struct QrSink {
    /// `T` (public `(u, u̇, v, v̇)` → scaled `(u, u̇, w, ẇ)`) and its inverse.
    t: Mat4,
    t_inv: Mat4,
    q: Mat4,
    product: Mat4,
    frame: Frame,
}

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
            product: IDENTITY,
            frame: Frame::new(4, restitution, compliant),
        }
    }

    /// Re-orthonormalise: `Q ← qr(T·product·T⁻¹·Q)`, accumulating `ln Rᵢᵢ`.
    fn flush(&mut self) {
        if self.frame.steps == 0 {
            return;
        }
        let ms = mat_mul(&self.t, &mat_mul(&self.product, &self.t_inv));
        let a = mat_mul(&ms, &self.q);
        let mut cols: Vec<Vec<f64>> = (0..4).map(|c| (0..4).map(|r| a[r][c]).collect()).collect();
        self.frame.orthonormalise(&mut cols);
        self.q = std::array::from_fn(|r| std::array::from_fn(|c| cols[c][r]));
        self.product = IDENTITY;
    }
}

impl TangentSink for QrSink {
    fn apply(&mut self, m: &Mat4, step: Step) {
        let due = self.frame.note(&step);
        self.product = mat_mul(m, &self.product);
        if due {
            self.flush();
        }
    }
}

/// A bar's variational run as the spectrum's block loop sees it.
trait TangentRun {
    /// The solver's state.
    type State;
    /// Run from `x` to `t_end_s` carrying the frame and re-orthonormalise at the end; the final
    /// state.
    fn block(&mut self, x: &Self::State, t_end_s: f64) -> Result<Self::State, SimError>;
    /// The frame.
    fn frame(&mut self) -> &mut Frame;
    /// The events so far and the approach memory's `Σ ln|1 + cᵀW⁻¹ζ|`.
    fn tally(&self) -> (EventCounts, f64);
}

/// The checks of the settings and the scales every spectrum makes.
fn check_settings(p: &SpectrumParams, sc: &StateScales) -> Result<(), SimError> {
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
    super::lyapunov::check_scales(sc)
}

/// The block loop of a spectrum from `x` (after the transient) at `t0`: each block one run,
/// its `ln Rᵢᵢ` per second; the exponents are the block means, their standard errors from the
/// spread, with the run's events and approach memory.
fn blocks<R: TangentRun>(
    run: &mut R,
    mut x: R::State,
    t0: f64,
    p: &SpectrumParams,
) -> Result<SpectrumResult, SimError> {
    let block = p.duration_s / p.blocks as f64;
    let mut block_rates: Vec<Vec<f64>> = Vec::with_capacity(p.blocks);
    for b in 1..=p.blocks {
        let t_end = t0 + b as f64 * block;
        run.frame().logs.iter_mut().for_each(|l| *l = 0.0);
        x = run.block(&x, t_end)?;
        let dt = t_end - (t0 + (b - 1) as f64 * block);
        block_rates.push(run.frame().logs.iter().map(|l| l / dt).collect());
    }
    let n = block_rates.len() as f64;
    let (events, memory) = run.tally();
    let frame = run.frame();
    let d = frame.logs.len();
    let mut exps = Vec::with_capacity(d);
    let mut errs = Vec::with_capacity(d);
    let mut sum = 0.0;
    for i in 0..d {
        if frame.collapsed[i] {
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
            return Err(SimError::NonFinite {
                t_s: t0 + p.duration_s,
            });
        }
        sum += mean;
        exps.push(Some(mean));
        errs.push(Some((var_i / n).sqrt()));
    }
    Ok(SpectrumResult {
        exponents_per_s: exps,
        std_error_per_s: errs,
        collapsed: frame.collapsed.iter().filter(|c| **c).count(),
        sum_per_s: sum,
        impacts_per_s: frame.impacts as f64 / p.duration_s,
        events,
        approach_memory_per_s: memory / p.duration_s,
        duration_s: p.duration_s,
    })
}

/// The lumped bar's run: its solver and the variational layer with the QR sink.
struct LumpedRun<'a> {
    sys: &'a System,
    solver: &'a dyn Solver,
    var: Variational<QrSink>,
    lg: f64,
}

impl TangentRun for LumpedRun<'_> {
    type State = State;

    fn block(&mut self, x: &State, t_end_s: f64) -> Result<State, SimError> {
        let mut s = self
            .solver
            .run(self.sys, x, t_end_s, &mut self.var)?
            .final_state;
        // The public state carries `v = u + w` rounded: a ball on a wall may read an ulp outside
        // it, which the next run's check refuses. Put it back on the wall (as `max_lyapunov`
        // does).
        super::lyapunov::onto_cavity(&mut s, self.lg);
        self.var.conclude()?;
        self.var.sink.flush();
        Ok(s)
    }

    fn frame(&mut self) -> &mut Frame {
        &mut self.var.sink.frame
    }

    fn tally(&self) -> (EventCounts, f64) {
        (self.var.counts, self.var.approach_memory_log)
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
    let sc = p.scales.unwrap_or_else(|| StateScales::for_system(sys));
    check_settings(p, &sc)?;
    // Refuses what the variational layer cannot do before any run.
    let e = sys.damper.map_or(1.0, |d| d.restitution);
    let compliant = sys
        .damper
        .is_some_and(|d| d.contact.law == crate::params::ContactLaw::Hertz);
    let var = Variational::new(sys, QrSink::new(&sc, e, compliant))?;
    let lg = sys.damper.map_or(f64::INFINITY, |d| d.half_gap_m());
    let mut x = solver
        .run(sys, init, init.t_s + p.transient_s, &mut ())?
        .final_state;
    super::lyapunov::onto_cavity(&mut x, lg);
    let t0 = x.t_s;
    let mut run = LumpedRun {
        sys,
        solver,
        var,
        lg,
    };
    blocks(&mut run, x, t0, p)
}

/// The N-mode bar's run: [`ModalExact`] and the modal variational layer with the frame.
struct ModalRun<'a> {
    sys: &'a ModalSystem,
    var: ModalVariational,
}

impl TangentRun for ModalRun<'_> {
    type State = ModalState;

    fn block(&mut self, x: &ModalState, t_end_s: f64) -> Result<ModalState, SimError> {
        self.var.restart_at(x);
        let mut s = ModalExact::default()
            .run_modal(self.sys, x, t_end_s, &mut self.var)?
            .final_state;
        // A block that ends inside a compliant contact: the next run starts on the wall.
        super::lyapunov::onto_cavity_modal(&mut s, self.sys);
        self.var.conclude()?;
        self.var.flush();
        Ok(s)
    }

    fn frame(&mut self) -> &mut Frame {
        &mut self.var.qr_state().expect("set by with_qr").frame
    }

    fn tally(&self) -> (EventCounts, f64) {
        (self.var.counts, self.var.approach_memory_log)
    }
}

/// `Σₙ cₙ/mₙ = Σₙ 2ζₙωₙ`: the free flight's rate of phase-volume contraction, 1/s.
pub fn modal_volume_contraction_per_s(sys: &ModalSystem) -> f64 {
    sys.model
        .modes()
        .iter()
        .map(|m| 2.0 * m.damping_ratio * m.omega_rad_s)
        .sum()
}

/// The Lyapunov spectrum of the modal system `sys` (a ball, either contact law) from `init`,
/// with [`ModalExact`] (module docs).
pub fn lyapunov_spectrum_modal(
    sys: &ModalSystem,
    init: &ModalState,
    p: &SpectrumParams,
) -> Result<SpectrumResult, SimError> {
    let sc = p
        .scales
        .unwrap_or_else(|| StateScales::for_system(&sys.to_system()));
    check_settings(p, &sc)?;
    let n = sys.n_modes();
    let mut scale = [0.0; D_MAX];
    for i in 0..n {
        scale[i] = sc.u_m;
        scale[n + i] = sc.du_m_s;
    }
    scale[2 * n] = sc.u_m + sc.w_m;
    scale[2 * n + 1] = sc.du_m_s + sc.dw_m_s;
    // Refuses what the variational layer cannot do before any run.
    let var = ModalVariational::new_modal(sys, init)?.with_qr(scale);
    let mut x = ModalExact::default()
        .run(sys, init, init.t_s + p.transient_s, &mut ())?
        .final_state;
    super::lyapunov::onto_cavity_modal(&mut x, sys);
    let t0 = x.t_s;
    let mut run = ModalRun { sys, var };
    blocks(&mut run, x, t0, p)
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
