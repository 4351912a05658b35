//! Two-parameter continuation in (frequency ratio, gap) of a codimension-one point of a periodic
//! orbit: a fold, a period doubling, a torus (Neimark–Sacker), a symmetry-breaking branch point
//! or a grazing contact.
//!
//! **Both bars.** The scheme is written once over the bar's map ([`Curve2Flow`], a [`Flow`] whose
//! ratio and gap can be set): the lumped bar ([`Section`], state `(u, u̇, w, ẇ)`, `D = 4`) and the
//! N-mode bar ([`ModalSection`], `[beam]` or `[[modes]]`, state `(q, q̇, w, ẇ)`, `D = 2N + 2`).
//!
//! **Augmented system.** Unknowns `z = (ξ, a, b)` (`D + 2` of them): the scaled state at the
//! section `ξ = x/s` ([`Flow::scales`] of the start, kept along the curve), the ratio
//! `r = a·`[`RATIO_UNIT`] and the gap `g = b·`[`GAP_UNIT_M`]. Equations `H(z) = (F(z), φ(z)) = 0`:
//! the orbit condition `F` (`D` rows) and one smooth test function `φ` of the kind
//! ([`CurveKind`]). `D + 1` equations in `D + 2` unknowns: a curve, followed by pseudo-arclength (predict along the kernel of `DH`, correct
//! with Newton on `H = 0` plus `t·(z − z_pred) = 0`).
//!
//! **The map.** For an orbit with the symmetry `x(t + kT/2) = −x(t)` (odd `k`: the symmetric
//! two-impact orbit, on either bar: [`symmetry_defect`]) the orbit condition is the half map's, `G(x) = −P_{kT/2}(x) = x`, with
//! Jacobian `M = −DP_{kT/2}`; the monodromy is `M²` and its multipliers are the squares of `M`'s.
//! This is what makes the symmetry-breaking branch point a regular point: there a multiplier of
//! `M` is `−1` (the monodromy's `+1` with an antisymmetric eigenvector), while on the full map
//! the orbit condition itself is singular (both branches cross). Any other orbit uses the full
//! map `P_{kT}`, `M = DP`.
//!
//! **Test functions** (on `M` in scaled coordinates; `J = M²` or `M` the monodromy):
//! * `fold`: `det(M − I)` (a multiplier `+1` of the map solved);
//! * `branch-point`: `det(M + I)` (symmetric orbits only: the monodromy's `+1` breaking the
//!   symmetry);
//! * `period-doubling`: `det(J + I)`;
//! * `torus`: `|λ|² − 1` of the complex pair of `J` nearest the unit circle (defined while the
//!   pair is complex: where it meets the real axis the torus curve ends at a strong resonance);
//! * `grazing`: the slowest impact's relative speed `|ẇ−|/s_ẇ` (an impact disappears), or the
//!   smallest clearance at an interior turning point of `|w|`, `(l_g − |w|)/l_g` (an impact
//!   appears), whichever is smaller at the start.
//!
//! **Derivatives.** The state columns of `F` are exact on both bars: `DP` with saltation matrices
//! from the variational layer. The parameter columns `∂P/∂r`, `∂P/∂g` are exact on the lumped bar
//! (its variational layer carries them: two runs; for the ratio with the moving end time). The
//! modal variational layer does not carry them: on the N-mode bar they are central differences of
//! the map solved, step [`PARAM_FD_STEP`] in scaled units (four runs; for the ratio the end time
//! moves with it), as the one-parameter continuation takes them there
//! ([`super::continuation`]). They only steer the corrector and the tangent: a converged point
//! solves `H = 0` whatever their error. The row of `φ` is by central differences of `φ` in each of
//! the `D + 2` unknowns (step [`FD_STEP`] in scaled units, `2D + 4` runs: the second derivatives
//! of the map that the exact gradient would need are not carried).
//!
//! **Ends of a curve.** Along the curve the other multipliers are watched; a change of the number
//! of multipliers beyond `+1`, beyond `−1` or complex outside the unit circle (the curve's own
//! critical multiplier left out) is a codimension-two point where the curve meets another
//! bifurcation curve, reported on the point past it ([`Codim2`]). A change of the event sequence
//! is reported as `grazing` (the curve meets a grazing curve). The curve stops at the ends of the
//! ratio and gap box, when the torus pair becomes real (strong resonance), when the orbit loses
//! its impacts or confinement (it leaves the physical orbits), or when the corrector fails at the
//! smallest step; the reason is in [`Curve::stop_reasons`].

use super::continuation::BranchEvent;
use super::modal::{to_relative as modal_to_relative, ModalSection};
use super::{describe, to_relative, to_vector, Flow, Orbit, PeriodicOrbit, Section};
use crate::analysis::grid::Axis;
use crate::analysis::variational::modal::modal_flow_with_jacobian;
use crate::analysis::variational::{flow_with_jacobian, flow_with_param_derivative, Param};
use crate::error::{ParamError, SimError};
use crate::params::System;
use crate::solver::Exact;
use crate::structure::ModalSystem;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

/// The unit of the ratio in the continuation's unknowns.
pub const RATIO_UNIT: f64 = 0.01;
/// The unit of the gap in the continuation's unknowns, m (0.01 mm).
pub const GAP_UNIT_M: f64 = 1e-5;
/// Central-difference step of the test function's gradient, in scaled units.
pub const FD_STEP: f64 = 1e-5;
/// Central-difference step of the parameter columns where the variational layer does not carry
/// them (the N-mode bar), in scaled units: `1e-7` in the ratio, `1e-10` m in the gap.
pub const PARAM_FD_STEP: f64 = 1e-5;

/// The codimension-one point a curve follows (`--kind`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CurveKind {
    /// A multiplier `+1` with a fold of the orbit family.
    Fold,
    /// A multiplier `−1`.
    PeriodDoubling,
    /// A complex pair on the unit circle.
    Torus,
    /// A symmetry-breaking branch point of a symmetric orbit.
    BranchPoint,
    /// An impact with zero relative speed, or a flight touching a wall.
    Grazing,
}

/// The kinds by their names (`--kind`).
pub const CURVE_KINDS: [(&str, CurveKind); 5] = [
    ("fold", CurveKind::Fold),
    ("period-doubling", CurveKind::PeriodDoubling),
    ("torus", CurveKind::Torus),
    ("branch-point", CurveKind::BranchPoint),
    ("grazing", CurveKind::Grazing),
];

impl CurveKind {
    /// The name in output files, that of the one-parameter event ([`BranchEvent::as_str`]).
    pub fn as_str(&self) -> &'static str {
        self.event().as_str()
    }

    /// The one-parameter event this kind continues.
    pub fn event(&self) -> BranchEvent {
        match self {
            CurveKind::Fold => BranchEvent::Fold,
            CurveKind::PeriodDoubling => BranchEvent::PeriodDoubling,
            CurveKind::Torus => BranchEvent::Torus,
            CurveKind::BranchPoint => BranchEvent::BranchPoint,
            CurveKind::Grazing => BranchEvent::Grazing,
        }
    }

    /// The kind of a one-parameter event (`stick-onset` has none).
    pub fn of_event(e: BranchEvent) -> Option<CurveKind> {
        CURVE_KINDS
            .iter()
            .find(|(_, k)| k.event() == e)
            .map(|(_, k)| *k)
    }

    /// Parse a `--kind` value; the error names the flag and lists the kinds.
    pub fn parse(s: &str) -> Result<CurveKind, String> {
        CURVE_KINDS
            .iter()
            .find(|(n, _)| *n == s)
            .map(|(_, k)| *k)
            .ok_or_else(|| {
                let names: Vec<&str> = CURVE_KINDS.iter().map(|(n, _)| *n).collect();
                format!("--kind must be one of {}, got {s:?}", names.join(", "))
            })
    }
}

/// A codimension-two point met along a curve, located by bisection on the step (to 1e-10 of it)
/// and reported on the located point (the first point past it in the direction it was followed).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Codim2 {
    /// Another real multiplier of the map solved crossed `+1` (the curve meets a fold curve; on
    /// the full map of an orbit without the symmetry, a fold or branch-point curve).
    MeetsFold,
    /// On a symmetric orbit's half map, another real multiplier crossed `−1` (the monodromy's
    /// `+1` that breaks the symmetry: meets a branch-point curve).
    MeetsBranchPoint,
    /// Another real multiplier crossed `−1` (meets a period-doubling curve).
    MeetsPeriodDoubling,
    /// Another complex pair crossed the unit circle (meets a torus curve).
    MeetsTorus,
    /// The event sequence changed (meets a grazing curve).
    MeetsGrazing,
    /// Two multipliers at `+1` or `−1` (strong resonance 1:1 or 1:2): where a torus curve ends
    /// on a fold or period-doubling curve.
    StrongResonance,
}

impl Codim2 {
    /// The name in output files.
    pub fn as_str(&self) -> &'static str {
        match self {
            Codim2::MeetsFold => "meets-fold",
            Codim2::MeetsBranchPoint => "meets-branch-point",
            Codim2::MeetsPeriodDoubling => "meets-period-doubling",
            Codim2::MeetsTorus => "meets-torus",
            Codim2::MeetsGrazing => "meets-grazing",
            Codim2::StrongResonance => "strong-resonance",
        }
    }
}

/// Settings of a two-parameter continuation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Curve2Settings {
    /// Ratio interval `[lo, hi]` the curve may cover (`--ratios`).
    pub ratios: (f64, f64),
    /// Gap interval `[lo, hi]` in metres (`--gaps-mm`).
    pub gaps_m: (f64, f64),
    /// Most points on each side of the start.
    pub max_points: usize,
    /// First step (scaled units: [`RATIO_UNIT`], [`GAP_UNIT_M`], the state scales).
    pub step_initial: f64,
    /// Smallest step before giving up.
    pub step_min: f64,
    /// Largest step.
    pub step_max: f64,
    /// Corrector iterations.
    pub max_iterations: usize,
    /// Corrector tolerance on `max |H|`.
    pub tolerance: f64,
}

impl Default for Curve2Settings {
    fn default() -> Self {
        Curve2Settings {
            ratios: (0.95, 1.05),
            gaps_m: (1e-6, 1e-3),
            max_points: 400,
            step_initial: 0.05,
            step_min: 1e-6,
            step_max: 0.4,
            max_iterations: 10,
            tolerance: 1e-9,
        }
    }
}

/// One point of a curve.
#[derive(Debug, Clone, PartialEq)]
pub struct CurvePoint<F: Flow = Section> {
    /// Frequency ratio.
    pub ratio: f64,
    /// Gap, m.
    pub gap_m: f64,
    /// The orbit there (full period, monodromy multipliers).
    pub orbit: Orbit<F>,
    /// The test function's value (≈ 0).
    pub test: f64,
    /// `max |F|` of the orbit condition, scaled units.
    pub residual: f64,
    /// A codimension-two point between the previous point and this one.
    pub event: Option<Codim2>,
}

/// A two-parameter curve.
#[derive(Debug, Clone, PartialEq)]
pub struct Curve<F: Flow = Section> {
    /// What it follows.
    pub kind: CurveKind,
    /// Whether the symmetric half map was used.
    pub symmetric: bool,
    /// Points in order of increasing arclength (the start's backward side reversed first).
    pub points: Vec<CurvePoint<F>>,
    /// Why each end stopped: `[backward, forward]`.
    pub stop_reasons: Vec<String>,
}

/// Which grazing quantity a grazing curve zeroes.
#[derive(Debug, Clone, Copy, PartialEq)]
enum GrazingMeasure {
    ImpactSpeed,
    TurningClearance,
}

/// A bar's map as the two-parameter continuation sees it: the [`Flow`] at any (ratio, gap), the
/// map and its Jacobian over the duration solved (half or full period), and the parameter columns
/// where the variational layer carries them (module docs, "Both bars").
pub trait Curve2Flow: Flow {
    /// The same bar at frequency ratio `ratio` and gap `gap_m` (SI), section time `t0_s`, period
    /// `periods`, checked.
    fn at_ratio_gap(
        &self,
        ratio: f64,
        gap_m: f64,
        t0_s: f64,
        periods: u32,
    ) -> Result<Self, SimError>;

    /// The frequency ratio and the gap (m) of this section's system.
    fn ratio_gap(&self) -> (f64, f64);

    /// The map over `dur_s` from the section time, `x(t₀ + dur)`, and its Jacobian in the map's
    /// coordinates.
    fn map_over(&self, x: &[f64], dur_s: f64) -> Result<(Vec<f64>, DMatrix<f64>), SimError>;

    /// The map over `dur_s`, its Jacobian and the exact columns `∂x(t₀ + dur)/∂r`,
    /// `∂x(t₀ + dur)/∂g` (SI, in the map's coordinates; for the ratio with the end time moving
    /// as `dur ∝ 1/r`), or `None` where the variational layer does not carry the parameters
    /// (then central differences of the map, [`PARAM_FD_STEP`]). `ratio` is the ratio as set
    /// (that of [`Curve2Flow::at_ratio_gap`]).
    #[allow(clippy::type_complexity)]
    fn map_with_param_columns(
        &self,
        x: &[f64],
        dur_s: f64,
        ratio: f64,
    ) -> Result<Option<(Vec<f64>, DMatrix<f64>, Vec<f64>, Vec<f64>)>, SimError>;
}

impl Curve2Flow for Section {
    fn at_ratio_gap(
        &self,
        ratio: f64,
        gap_m: f64,
        t0_s: f64,
        periods: u32,
    ) -> Result<Section, SimError> {
        let mut s = self.system;
        Axis::FreqRatio.apply(&mut s, ratio)?;
        Axis::GapM.apply(&mut s, gap_m)?;
        s.validate()?;
        Section::new(s, t0_s, periods)
    }

    fn ratio_gap(&self) -> (f64, f64) {
        (
            super::continuation::param_of(&self.system, Axis::FreqRatio),
            super::continuation::param_of(&self.system, Axis::GapM),
        )
    }

    fn map_over(&self, x: &[f64], dur_s: f64) -> Result<(Vec<f64>, DMatrix<f64>), SimError> {
        let init = Flow::state(self, x);
        let fj = flow_with_jacobian(
            &Exact::default(),
            &self.system,
            &init,
            self.t0_s + dur_s,
            &mut (),
        )?;
        Ok((to_vector(&fj.state).to_vec(), to_relative(&fj.jacobian)))
    }

    fn map_with_param_columns(
        &self,
        x: &[f64],
        dur_s: f64,
        ratio: f64,
    ) -> Result<Option<(Vec<f64>, DMatrix<f64>, Vec<f64>, Vec<f64>)>, SimError> {
        let init = Flow::state(self, x);
        let col =
            |p: Param| -> Result<(crate::analysis::variational::FlowJacobian, Vec<f64>), SimError> {
                let (fj, mut d) = flow_with_param_derivative(
                    &Exact::default(),
                    &self.system,
                    &init,
                    self.t0_s + dur_s,
                    p,
                    &mut (),
                )?;
                if p == Param::FreqRatio {
                    // The end time t₀ + dur(r) moves: ∂t_end/∂r = −dur/r.
                    let dt = -dur_s / ratio;
                    for (di, fi) in d.iter_mut().zip(fj.end_field) {
                        *di += fi * dt;
                    }
                }
                Ok((fj, vec![d[0], d[1], d[2] - d[0], d[3] - d[1]]))
            };
        let (fj, dr) = col(Param::FreqRatio)?;
        let (_, dg) = col(Param::GapM)?;
        Ok(Some((
            to_vector(&fj.state).to_vec(),
            to_relative(&fj.jacobian),
            dr,
            dg,
        )))
    }
}

impl Curve2Flow for ModalSection {
    fn at_ratio_gap(
        &self,
        ratio: f64,
        gap_m: f64,
        t0_s: f64,
        periods: u32,
    ) -> Result<ModalSection, SimError> {
        let mut s = self.system.to_system();
        Axis::FreqRatio.apply(&mut s, ratio)?;
        Axis::GapM.apply(&mut s, gap_m)?;
        let m = ModalSystem::from_system(&s)?;
        m.validate()?;
        ModalSection::new(m, t0_s, periods)
    }

    fn ratio_gap(&self) -> (f64, f64) {
        let s = self.system.to_system();
        (
            super::continuation::param_of(&s, Axis::FreqRatio),
            super::continuation::param_of(&s, Axis::GapM),
        )
    }

    fn map_over(&self, x: &[f64], dur_s: f64) -> Result<(Vec<f64>, DMatrix<f64>), SimError> {
        let fj = modal_flow_with_jacobian(&self.system, &self.state(x), self.t0_s + dur_s)?;
        let d = self.dim();
        let j = DMatrix::from_fn(d, d, |r, c| fj.jacobian[r][c]);
        Ok((
            self.to_vector(&fj.state),
            modal_to_relative(&self.system, &j),
        ))
    }

    fn map_with_param_columns(
        &self,
        _: &[f64],
        _: f64,
        _: f64,
    ) -> Result<Option<(Vec<f64>, DMatrix<f64>, Vec<f64>, Vec<f64>)>, SimError> {
        // The modal variational layer carries no parameter column: central differences.
        Ok(None)
    }
}

struct Ctx<F: Curve2Flow> {
    /// The start's section: the bar whose ratio and gap are set.
    base: F,
    kind: CurveKind,
    symmetric: bool,
    periods: u32,
    /// The state's dimension `D`.
    d: usize,
    sc: Vec<f64>,
    grazing: GrazingMeasure,
    settings: Curve2Settings,
}

/// The map's value, scaled Jacobian `M` (map solved) and the two scaled parameter columns.
struct MapEval {
    fx: Vec<f64>,
    m: DMatrix<f64>,
    dr: Vec<f64>,
    dg: Vec<f64>,
}

/// `H(z)`, `DH` (top `D + 1` rows of a square matrix) and `M`.
type Eval = (DVector<f64>, DMatrix<f64>, DMatrix<f64>);

#[derive(Clone)]
struct Pt<F: Flow> {
    z: DVector<f64>,
    t0: f64,
    tangent: DVector<f64>,
    point: CurvePoint<F>,
    /// `M` (scaled) at the point.
    m: DMatrix<f64>,
}

impl<F: Curve2Flow> Ctx<F> {
    fn section(&self, t0: f64, z: &DVector<f64>) -> Result<F, SimError> {
        let d = self.d;
        self.base
            .at_ratio_gap(z[d] * RATIO_UNIT, z[d + 1] * GAP_UNIT_M, t0, self.periods)
    }

    fn x_of(&self, sec: &F, z: &DVector<f64>) -> Vec<f64> {
        let x: Vec<f64> = (0..self.d).map(|i| z[i] * self.sc[i]).collect();
        sec.clamp(&x)
    }

    /// The duration of the map solved.
    fn duration(&self, sec: &F) -> f64 {
        if self.symmetric {
            0.5 * sec.period_s()
        } else {
            sec.period_s()
        }
    }

    fn sign(&self) -> f64 {
        if self.symmetric {
            -1.0
        } else {
            1.0
        }
    }

    /// `M` in scaled coordinates from the Jacobian `j` of the map (SI).
    fn scale_m(&self, j: &DMatrix<f64>) -> DMatrix<f64> {
        let sg = self.sign();
        DMatrix::from_fn(self.d, self.d, |i, k| {
            sg * j[(i, k)] * self.sc[k] / self.sc[i]
        })
    }

    /// `G(x)` and `M = DG` (scaled); with `params`, also `∂G/∂(a, b)` (scaled).
    fn map_eval(&self, t0: f64, z: &DVector<f64>, params: bool) -> Result<MapEval, SimError> {
        let d = self.d;
        let sec = self.section(t0, z)?;
        let x = self.x_of(&sec, z);
        let dur = self.duration(&sec);
        let sg = self.sign();
        let scaled = |v: &[f64], unit: f64| -> Vec<f64> {
            (0..d).map(|i| sg * v[i] * unit / self.sc[i]).collect()
        };
        if !params {
            let (v, j) = sec.map_over(&x, dur)?;
            return Ok(MapEval {
                fx: (0..d).map(|i| sg * v[i]).collect(),
                m: self.scale_m(&j),
                dr: vec![0.0; d],
                dg: vec![0.0; d],
            });
        }
        let (v, j, dr, dg) = match sec.map_with_param_columns(&x, dur, z[d] * RATIO_UNIT)? {
            Some(cols) => cols,
            None => {
                // Central differences of the map solved in the scaled parameters (step
                // PARAM_FD_STEP): for the ratio the end time t₀ + dur(r) moves with it.
                let (v, j) = sec.map_over(&x, dur)?;
                let run = |dz: usize, h: f64| -> Result<Vec<f64>, SimError> {
                    let mut zz = z.clone();
                    zz[dz] += h;
                    let s = self.section(t0, &zz)?;
                    Ok(s.map_over(&x, self.duration(&s))?.0)
                };
                let col = |dz: usize, unit: f64| -> Result<Vec<f64>, SimError> {
                    let (a, b) = (run(dz, PARAM_FD_STEP)?, run(dz, -PARAM_FD_STEP)?);
                    Ok((0..d)
                        .map(|i| (a[i] - b[i]) / (2.0 * PARAM_FD_STEP * unit))
                        .collect())
                };
                let (dr, dg) = (col(d, RATIO_UNIT)?, col(d + 1, GAP_UNIT_M)?);
                (v, j, dr, dg)
            }
        };
        Ok(MapEval {
            fx: (0..d).map(|i| sg * v[i]).collect(),
            m: self.scale_m(&j),
            dr: scaled(&dr, RATIO_UNIT),
            dg: scaled(&dg, GAP_UNIT_M),
        })
    }

    /// The monodromy (scaled) from `M`.
    fn monodromy(&self, m: &DMatrix<f64>) -> DMatrix<f64> {
        if self.symmetric {
            m * m
        } else {
            m.clone()
        }
    }

    /// The test function at `z`.
    fn test(&self, t0: f64, z: &DVector<f64>, m: Option<&DMatrix<f64>>) -> Result<f64, SimError> {
        if self.kind == CurveKind::Grazing {
            return self.grazing_value(t0, z);
        }
        let m = match m {
            Some(m) => m.clone(),
            None => self.map_eval(t0, z, false)?.m,
        };
        test_of_matrix(self.kind, &m, &self.monodromy(&m)).ok_or(SimError::NoConvergence {
            what: "the torus test function (the critical pair of multipliers is no longer complex: a strong resonance)",
            iterations: 0,
            residual: f64::NAN,
            tolerance: 0.0,
        })
    }

    fn grazing_value(&self, t0: f64, z: &DVector<f64>) -> Result<f64, SimError> {
        let sec = self.section(t0, z)?;
        let x = self.x_of(&sec, z);
        let o = describe(&sec, &x, DMatrix::identity(self.d, self.d), "none", 0.0, 0)?;
        let lg = sec.half_gap_m();
        Ok(match self.grazing {
            GrazingMeasure::ImpactSpeed => o.physicality.min_impact_speed_m_s / self.sc[self.d - 1],
            GrazingMeasure::TurningClearance => o.physicality.grazing_margin_m / lg,
        })
    }

    /// `H(z)` and `DH` (top `D + 1` rows of a `(D + 2)`-square matrix), and `M`.
    fn eval(&self, t0: f64, z: &DVector<f64>) -> Result<Eval, SimError> {
        let d = self.d;
        let me = self.map_eval(t0, z, true)?;
        let mut h = DVector::zeros(d + 2);
        let mut j = DMatrix::zeros(d + 2, d + 2);
        for i in 0..d {
            h[i] = me.fx[i] / self.sc[i] - z[i];
            for k in 0..d {
                j[(i, k)] = me.m[(i, k)] - if i == k { 1.0 } else { 0.0 };
            }
            j[(i, d)] = me.dr[i];
            j[(i, d + 1)] = me.dg[i];
        }
        h[d] = self.test(t0, z, Some(&me.m))?;
        for k in 0..d + 2 {
            let mut zp = z.clone();
            let mut zm = z.clone();
            zp[k] += FD_STEP;
            zm[k] -= FD_STEP;
            let (a, b) = (self.test(t0, &zp, None)?, self.test(t0, &zm, None)?);
            j[(d, k)] = (a - b) / (2.0 * FD_STEP);
        }
        Ok((h, j, me.m))
    }

    fn tangent(&self, j: &DMatrix<f64>, prev: &DVector<f64>) -> Option<DVector<f64>> {
        let n = self.d + 2;
        let mut m = j.clone();
        for k in 0..n {
            m[(n - 1, k)] = prev[k];
        }
        let mut rhs = DVector::zeros(n);
        rhs[n - 1] = 1.0;
        let t = m.lu().solve(&rhs)?;
        let nrm = t.norm();
        (nrm.is_finite() && nrm > 0.0).then(|| t / nrm)
    }

    /// Newton on `H = 0` with the last row `row·(z − z_pred) = 0`.
    fn correct(
        &self,
        t0: f64,
        z_pred: &DVector<f64>,
        row: &DVector<f64>,
    ) -> Result<Eval, SimError> {
        let n = self.d + 2;
        let mut z = z_pred.clone();
        let tol = self.settings.tolerance;
        let mut last = f64::INFINITY;
        for it in 0..=self.settings.max_iterations {
            let (h, mut j, m) = match self.eval(t0, &z) {
                Ok(e) => e,
                // After a step, a state or parameter the solver refuses is the step's failure (a
                // diverging iteration), not the input's.
                Err(_) if it > 0 => {
                    return Err(SimError::NoConvergence {
                        what: "the two-parameter corrector (a step left the solver's domain)",
                        iterations: it,
                        residual: last,
                        tolerance: tol,
                    })
                }
                Err(e) => return Err(e),
            };
            let r = h.amax();
            if r <= tol && it > 0 {
                return Ok((z, j, m));
            }
            if it == self.settings.max_iterations || r.is_nan() || r >= 10.0 * last.max(tol) {
                return Err(SimError::NoConvergence {
                    what: "the two-parameter corrector",
                    iterations: it,
                    residual: r,
                    tolerance: tol,
                });
            }
            last = r;
            let mut rhs = -h;
            for k in 0..n {
                j[(n - 1, k)] = row[k];
            }
            rhs[n - 1] = -row.dot(&(&z - z_pred));
            let dz = j.lu().solve(&rhs).ok_or(SimError::NoConvergence {
                what: "the two-parameter corrector (singular Jacobian)",
                iterations: it,
                residual: r,
                tolerance: tol,
            })?;
            z += dz;
            let iw = self.d - 2;
            let lg = 0.5 * z[n - 1] * GAP_UNIT_M;
            // A step that leaves the gaps (0, ∞) fails like a diverging one (the step is halved).
            if lg.is_nan() || lg <= 0.0 {
                return Err(SimError::NoConvergence {
                    what: "the two-parameter corrector (a step left the positive gaps)",
                    iterations: it + 1,
                    residual: r,
                    tolerance: tol,
                });
            }
            z[iw] = z[iw].clamp(-lg / self.sc[iw], lg / self.sc[iw]);
        }
        unreachable!("the loop returns")
    }

    /// The full point at a converged `z`.
    fn point(
        &self,
        t0: f64,
        z: DVector<f64>,
        j: &DMatrix<f64>,
        m: DMatrix<f64>,
        prev_t: &DVector<f64>,
    ) -> Result<Pt<F>, SimError> {
        let d = self.d;
        let sec = self.section(t0, &z)?;
        let x = self.x_of(&sec, &z);
        let mono = self.monodromy(&m);
        let jac_si = DMatrix::from_fn(d, d, |i, k| mono[(i, k)] * self.sc[i] / self.sc[k]);
        let mut orbit = describe(&sec, &x, jac_si, "variational", 0.0, 0)?;
        let px = sec.flow(&x)?;
        orbit.residual = (0..d)
            .map(|i| ((px[i] - x[i]) / self.sc[i]).abs())
            .fold(0.0, f64::max);
        let tangent = self.tangent(j, prev_t).ok_or(SimError::NoConvergence {
            what: "the two-parameter tangent (singular extended Jacobian)",
            iterations: 0,
            residual: f64::NAN,
            tolerance: 0.0,
        })?;
        let test = self.test(t0, &z, Some(&m))?;
        Ok(Pt {
            t0,
            tangent,
            point: CurvePoint {
                ratio: z[d] * RATIO_UNIT,
                gap_m: z[d + 1] * GAP_UNIT_M,
                residual: orbit.residual,
                orbit,
                test,
                event: None,
            },
            z,
            m,
        })
    }

    /// Move the section away from an event within 2 % of the solved map's duration of it (either
    /// end).
    fn rephase(&self, p: Pt<F>) -> Result<Pt<F>, SimError> {
        let d = self.d;
        let o = &p.point.orbit;
        let kt = o.section.period_s();
        let dur = self.duration(&o.section);
        let near = o.events.iter().any(|e| {
            let r = e.dt_s % dur;
            r < 0.02 * dur || r > 0.98 * dur
        });
        if !near || o.events.is_empty() {
            return Ok(p);
        }
        let mut times: Vec<f64> = o.events.iter().map(|e| e.dt_s).collect();
        times.push(o.events[0].dt_s + kt);
        let (mut best, mut mid) = (-1.0, 0.5 * kt);
        for w in times.windows(2) {
            if w[1] - w[0] > best {
                best = w[1] - w[0];
                mid = 0.5 * (w[0] + w[1]);
            }
        }
        let t_new = o.section.t0_s() + mid;
        let (s, _) = o.section.run(&o.state, t_new, &mut ())?;
        let tt = o.section.forcing_period_s();
        let t0 = t_new - (t_new / tt).floor() * tt;
        let x = o.section.vector(&s);
        let mut z = p.z.clone();
        for i in 0..d {
            z[i] = x[i] / self.sc[i];
        }
        let (_, j, m) = self.eval(t0, &z)?;
        let mut q = self.point(t0, z, &j, m, &p.tangent)?;
        // The state part of the old tangent is in the old section's coordinates: orient the new
        // one by its parameter part.
        if q.tangent[d] * p.tangent[d] + q.tangent[d + 1] * p.tangent[d + 1] < 0.0 {
            q.tangent = -q.tangent;
        }
        q.point.event = p.point.event;
        Ok(q)
    }
}

/// The test function of `kind` on the solved map's scaled Jacobian `m` and the monodromy `mono`
/// (`None` for a torus without a complex pair; grazing has none here).
fn test_of_matrix(kind: CurveKind, m: &DMatrix<f64>, mono: &DMatrix<f64>) -> Option<f64> {
    let id = DMatrix::<f64>::identity(m.nrows(), m.ncols());
    match kind {
        CurveKind::Fold => Some((m - &id).determinant()),
        CurveKind::BranchPoint => Some((m + &id).determinant()),
        CurveKind::PeriodDoubling => Some((mono + &id).determinant()),
        CurveKind::Torus => critical_pair(mono).map(|l| l.norm_sqr() - 1.0),
        CurveKind::Grazing => None,
    }
}

/// The complex multiplier (upper half plane) nearest the unit circle, if any.
fn critical_pair(mono: &DMatrix<f64>) -> Option<Complex64> {
    super::multipliers_of(mono)
        .into_iter()
        .filter(|l| l.im > 1e-9 * l.norm().max(1e-300))
        .min_by(|a, b| (a.norm() - 1.0).abs().total_cmp(&(b.norm() - 1.0).abs()))
}

/// Counts of the solved map's multipliers (those of `M`: the half map's for a symmetric orbit,
/// the monodromy's otherwise) beyond `+1`, beyond `−1`, complex outside the circle and complex in
/// all, leaving out the curve's own critical one(s).
fn counts(kind: CurveKind, m: &DMatrix<f64>) -> [usize; 4] {
    let mut list = super::multipliers_of(m);
    let one = Complex64::new(1.0, 0.0);
    let drop = |target: Complex64, list: &mut Vec<Complex64>| {
        if let Some(i) = nearest(list, target) {
            list.remove(i);
        }
    };
    match kind {
        CurveKind::Fold => drop(one, &mut list),
        CurveKind::BranchPoint => drop(-one, &mut list),
        // On a symmetric orbit's half map a period doubling is a pair at ±i; else −1.
        CurveKind::PeriodDoubling => {
            let i = Complex64::new(0.0, 1.0);
            let at_i = nearest(&list, i).is_some_and(|k| (list[k] - i).norm() < 1e-3);
            if at_i {
                drop(i, &mut list);
                drop(-i, &mut list);
            } else {
                drop(-one, &mut list);
            }
        }
        CurveKind::Torus => {
            if let Some(c) = critical_pair(m) {
                drop(c, &mut list);
                drop(c.conj(), &mut list);
            }
        }
        CurveKind::Grazing => {}
    }
    let mut out = [0usize; 4];
    for l in &list {
        let complex = l.im.abs() > 1e-9 * l.norm();
        if complex {
            out[3] += 1;
        }
        if l.norm() > 1.0 {
            if complex {
                out[2] += 1;
            } else if l.re > 0.0 {
                out[0] += 1;
            } else {
                out[1] += 1;
            }
        }
    }
    out
}

/// The smallest rotation of a cyclic event sequence (the same orbit seen from another section).
fn cyclic_canonical(s: &str) -> String {
    let c: Vec<char> = s.chars().collect();
    (0..c.len().max(1))
        .map(|r| {
            let r = r.min(c.len());
            c[r..].iter().chain(&c[..r]).collect::<String>()
        })
        .min()
        .unwrap_or_default()
}

fn nearest(v: &[Complex64], target: Complex64) -> Option<usize> {
    v.iter()
        .enumerate()
        .min_by(|a, b| (a.1 - target).norm().total_cmp(&(b.1 - target).norm()))
        .map(|(i, _)| i)
}

/// The codimension-two point between two count vectors ([`counts`]) and event sequences.
fn codim2_between(
    symmetric: bool,
    a: &[usize; 4],
    b: &[usize; 4],
    seq_a: &str,
    seq_b: &str,
) -> Option<Codim2> {
    if seq_a != seq_b {
        return Some(Codim2::MeetsGrazing);
    }
    // Only a change of the number of unstable multipliers is a crossing (a complex pair meeting
    // on the real axis outside the circle is not).
    let unstable = |c: &[usize; 4]| c[0] + c[1] + c[2];
    if unstable(a) == unstable(b) {
        return None;
    }
    if a[0] != b[0] {
        Some(Codim2::MeetsFold)
    } else if a[1] != b[1] {
        // On the half map a real multiplier through −1 is the monodromy's symmetry-breaking +1.
        Some(if symmetric {
            Codim2::MeetsBranchPoint
        } else {
            Codim2::MeetsPeriodDoubling
        })
    } else if a[2] != b[2] && a[3] == b[3] {
        Some(Codim2::MeetsTorus)
    } else {
        None
    }
}

/// A strong resonance at a located codimension-two point: two multipliers of the map solved
/// within 1e-3 of `+1` (1:1, where a torus curve ends on a fold curve) or of `−1`.
fn resonance(m: &DMatrix<f64>) -> Option<Codim2> {
    let l = super::multipliers_of(m);
    [1.0, -1.0]
        .iter()
        .any(|t| l.iter().filter(|x| (*x - t).norm() < 1e-3).count() >= 2)
        .then_some(Codim2::StrongResonance)
}

/// Whether `orbit` has the symmetry `x(t + kT/2) = −x(t)` (odd `k`, defect below 1e-6).
pub fn is_symmetric<F: Flow>(orbit: &Orbit<F>) -> Result<bool, SimError> {
    Ok(symmetry_defect(orbit)?.is_some_and(|d| d < 1e-6))
}

/// `max |x(t0 + kT/2) + x(t0)|` in scaled units, either bar: 0 for an orbit with the symmetry
/// `x(t + kT/2) = −x(t)`, `None` for an even `k` ([`Orbit::symmetry_defect`] of the lumped bar).
/// On the N-mode bar the symmetry is the same in its map's coordinates `(q, q̇, w, ẇ)`: the modal
/// equations are linear in `(q, q̇)`, the ball's `(w, ẇ)` meets walls at `±l_g` with the same law,
/// and the harmonic force changes sign over half a period (a static force breaks it: the defect
/// says so).
pub fn symmetry_defect<F: Flow>(orbit: &Orbit<F>) -> Result<Option<f64>, SimError> {
    let sec = &orbit.section;
    if sec.periods() % 2 == 0 {
        return Ok(None);
    }
    let half = sec.t0_s() + 0.5 * sec.period_s();
    let (s, _) = sec.run(&orbit.state, half, &mut ())?;
    let (a, b) = (sec.vector(&orbit.state), sec.vector(&s));
    let sc = sec.scales();
    Ok(Some(
        (0..a.len())
            .map(|i| ((a[i] + b[i]) / sc[i]).abs())
            .fold(0.0, f64::max),
    ))
}

/// Check the settings: finite, non-empty ratio and gap intervals, step and point limits. Errors
/// name the flags.
pub fn check_settings(s: &Curve2Settings) -> Result<(), ParamError> {
    for (flag, (lo, hi)) in [("--ratios", s.ratios), ("--gaps-mm", s.gaps_m)] {
        crate::params::finite(flag, lo)?;
        crate::params::finite(flag, hi)?;
        if hi <= lo || lo <= 0.0 {
            return Err(ParamError::OutOfRange {
                field: flag,
                value: hi - lo,
                allowed: "an interval A:B with 0 < A < B (the interval is empty or reversed)",
            });
        }
    }
    crate::limits::check_count(
        "points (--max-points)",
        s.max_points,
        2,
        crate::limits::MAX_CONTINUATION_POINTS,
        "",
    )?;
    crate::params::positive("step_min", s.step_min)?;
    if !(s.step_min <= s.step_initial && s.step_initial <= s.step_max) {
        return Err(ParamError::OutOfRange {
            field: "step_initial",
            value: s.step_initial,
            allowed: "[step_min, step_max]",
        });
    }
    Ok(())
}

/// Follow the `kind` curve through the codimension-one point near the orbit `start` (typically
/// the point a one-parameter continuation located: [`super::continuation::continue_orbit`]) in
/// both directions within the settings' box (module docs). The start is first corrected onto the
/// curve at its own ratio (Newton on the orbit condition and the test function in the state and
/// the gap).
pub fn continue_curve<F: Curve2Flow>(
    start: &Orbit<F>,
    kind: CurveKind,
    settings: &Curve2Settings,
) -> Result<Curve<F>, SimError> {
    check_settings(settings)?;
    let base = start.section.clone();
    let d = base.dim();
    let (ratio0, gap0) = base.ratio_gap();
    // Symmetric up to 1e-3 (a one-parameter detection next to a symmetry-breaking branch point may
    // sit slightly off the symmetric branch): the first correction projects it onto it.
    let symmetric = symmetry_defect(start)?.is_some_and(|d| d < 1e-3);
    if kind == CurveKind::BranchPoint && !symmetric {
        return Err(SimError::Unsupported(
            "--kind branch-point needs a symmetric orbit (x(t + kT/2) = −x(t), odd period) at the start: a symmetry-breaking branch point has one",
        ));
    }
    let lg = base.half_gap_m();
    let sc = base.scales();
    let grazing = {
        let ph = start.physicality;
        if ph.min_impact_speed_m_s / sc[d - 1] <= ph.grazing_margin_m / lg {
            GrazingMeasure::ImpactSpeed
        } else {
            GrazingMeasure::TurningClearance
        }
    };
    let c = Ctx {
        base,
        kind,
        // The grazing measure is taken over the full period.
        symmetric: symmetric && kind != CurveKind::Grazing,
        periods: start.section.periods(),
        d,
        sc,
        grazing,
        settings: *settings,
    };
    let x0 = start.vector();
    let mut z = DVector::zeros(d + 2);
    for i in 0..d {
        z[i] = x0[i] / c.sc[i];
    }
    z[d] = ratio0 / RATIO_UNIT;
    z[d + 1] = gap0 / GAP_UNIT_M;
    let t0 = start.section.t0_s();
    // Onto the curve at fixed ratio: the last row pins a.
    let mut e_r = DVector::zeros(d + 2);
    e_r[d] = 1.0;
    let (z, j, m) = c.correct(t0, &z, &e_r).map_err(|e| match e {
        SimError::NoConvergence {
            iterations,
            residual,
            tolerance,
            ..
        } => SimError::NoConvergence {
            what: "the start of the two-parameter curve (no point of this kind near the given one: start from a point the one-parameter `continue` located, with its --kind)",
            iterations,
            residual,
            tolerance,
        },
        e => e,
    })?;
    // Initial tangent: the kernel oriented toward increasing ratio (or gap if the curve is
    // vertical).
    let mut guess = DVector::zeros(d + 2);
    guess[d] = 1.0;
    guess[d + 1] = 1e-3;
    let first = c.rephase(c.point(t0, z, &j, m, &guess)?)?;
    let mut sides = Vec::new();
    let mut reasons = Vec::new();
    for dir in [-1.0, 1.0] {
        let mut s = first.clone();
        s.tangent *= dir;
        let mut pts = Vec::new();
        let reason = follow(&c, s, &mut pts)?;
        sides.push(pts);
        reasons.push(reason);
    }
    // Joined in arclength order: [b_n … b_1, start, f_1 …]; an event stays on its located point.
    let mut points: Vec<CurvePoint<F>> = sides[0].iter().rev().map(|p| p.point.clone()).collect();
    points.push(first.point.clone());
    points.extend(sides[1].iter().map(|p| p.point.clone()));
    Ok(Curve {
        kind,
        symmetric: c.symmetric,
        points,
        stop_reasons: reasons,
    })
}

/// One direction of a curve from `cur`; pushes the points after it, returns why it stopped.
fn follow<F: Curve2Flow>(
    c: &Ctx<F>,
    mut cur: Pt<F>,
    out: &mut Vec<Pt<F>>,
) -> Result<String, SimError> {
    let (rlo, rhi) = c.settings.ratios;
    let (glo, ghi) = c.settings.gaps_m;
    let bounds = [
        (c.d, rlo / RATIO_UNIT, rhi / RATIO_UNIT),
        (c.d + 1, glo / GAP_UNIT_M, ghi / GAP_UNIT_M),
    ];
    let mut h = c.settings.step_initial;
    loop {
        if out.len() >= c.settings.max_points {
            return Ok(format!("{} points reached", c.settings.max_points));
        }
        let o = &cur.point.orbit;
        if o.impacts_per_period == 0 || !o.physicality.confined {
            return Ok(format!(
                "the orbit left the physical orbits at ratio {:.6}, gap {:.6} mm ({})",
                cur.point.ratio,
                cur.point.gap_m * 1e3,
                if o.impacts_per_period == 0 {
                    "no impact left"
                } else {
                    "the ball is beyond a wall"
                }
            ));
        }
        if c.kind == CurveKind::Torus {
            if let Some(l) = critical_pair(&c.monodromy(&cur.m)) {
                if l.im.abs() < 1e-4 {
                    return Ok(format!(
                        "strong resonance at ratio {:.6}, gap {:.6} mm: the torus pair reached the real axis at λ ≈ {:+.4} (the curve ends on a {} curve)",
                        cur.point.ratio,
                        cur.point.gap_m * 1e3,
                        l.re,
                        if l.re > 0.0 { "fold or branch-point" } else { "period-doubling" }
                    ));
                }
            }
        }
        if h < c.settings.step_min {
            return Ok(format!(
                "step below {:e} at ratio {:.6}, gap {:.6} mm (the corrector fails{})",
                c.settings.step_min,
                cur.point.ratio,
                cur.point.gap_m * 1e3,
                if c.kind == CurveKind::Torus {
                    ": near a strong resonance the torus pair turns real"
                } else {
                    ": a nonsmooth point (grazing) or the end of the kind's curve"
                }
            ));
        }
        // Land on the box's edge.
        let mut hh = h;
        let mut pin: Option<(usize, f64)> = None;
        for (k, lo, hi) in bounds {
            let tk = cur.tangent[k];
            if tk.abs() < 1e-3 {
                continue;
            }
            let edge = if tk > 0.0 { hi } else { lo };
            let d = (edge - cur.z[k]) / tk;
            if d < hh {
                hh = d.max(0.0);
                pin = Some((k, edge));
            }
        }
        if hh <= 0.0 {
            return Ok("the edge of the ratio–gap box reached".into());
        }
        let attempt = step(c, &cur, hh, pin);
        let next = match attempt {
            Ok(p) => p,
            Err(_) => {
                h *= 0.5;
                continue;
            }
        };
        if next.tangent.dot(&cur.tangent) < 0.3f64.cos() && hh > 4.0 * c.settings.step_min {
            h = hh * 0.5;
            continue;
        }
        let (ca, cb) = (counts(c.kind, &cur.m), counts(c.kind, &next.m));
        let seq = |p: &Pt<F>| cyclic_canonical(&p.point.orbit.sequence);
        let mut next = next;
        let ev = codim2_between(c.symmetric, &ca, &cb, &seq(&cur), &seq(&next));
        if let Some(e) = ev {
            // Locate it by bisection on the step: the first point with the new counts.
            let (mut lo, mut hi) = (0.0, hh);
            let mut best: Option<Pt<F>> = None;
            for _ in 0..40 {
                if hi - lo < 1e-10 * hh.max(1e-12) {
                    break;
                }
                let mid = 0.5 * (lo + hi);
                let Ok(p) = step(c, &cur, mid, None) else {
                    break;
                };
                let same = codim2_between(
                    c.symmetric,
                    &ca,
                    &counts(c.kind, &p.m),
                    &seq(&cur),
                    &seq(&p),
                )
                .is_none();
                if same {
                    lo = mid;
                } else {
                    hi = mid;
                    best = Some(p);
                }
            }
            match best {
                Some(mut b) if (&b.z - &next.z).amax() > 1e-9 => {
                    b.point.event = Some(resonance(&b.m).unwrap_or(e));
                    out.push(b);
                }
                _ => next.point.event = Some(resonance(&next.m).unwrap_or(e)),
            }
        }
        let next = c.rephase(next)?;
        out.push(next.clone());
        cur = next;
        if pin.is_some() {
            return Ok(format!(
                "the edge of the ratio–gap box reached at ratio {:.6}, gap {:.6} mm",
                cur.point.ratio,
                cur.point.gap_m * 1e3
            ));
        }
        h = (h * 1.3).min(c.settings.step_max);
    }
}

fn step<F: Curve2Flow>(
    c: &Ctx<F>,
    cur: &Pt<F>,
    h: f64,
    pin: Option<(usize, f64)>,
) -> Result<Pt<F>, SimError> {
    let mut z_pred = &cur.z + &cur.tangent * h;
    let (z, j, m) = match pin {
        None => c.correct(cur.t0, &z_pred, &cur.tangent)?,
        Some((k, v)) => {
            let mut row = DVector::zeros(c.d + 2);
            row[k] = 1.0;
            z_pred[k] = v;
            c.correct(cur.t0, &z_pred, &row)?
        }
    };
    c.point(cur.t0, z, &j, m, &cur.tangent)
}

/// The value of `kind`'s test function at a converged orbit (`None` for grazing and a torus
/// without a complex pair): on the half map for a symmetric orbit (module docs). The check that
/// a curve point is a codimension-one point of the right kind.
pub fn test_function<F: Curve2Flow>(
    orbit: &Orbit<F>,
    kind: CurveKind,
) -> Result<Option<f64>, SimError> {
    let sec = &orbit.section;
    let sc = sec.scales();
    let symmetric = is_symmetric(orbit)?;
    let x = orbit.vector();
    let (dur, sg) = if symmetric {
        (0.5 * sec.period_s(), -1.0)
    } else {
        (sec.period_s(), 1.0)
    };
    let (_, j) = sec.map_over(&x, dur)?;
    let d = sec.dim();
    let m = DMatrix::from_fn(d, d, |i, k| sg * j[(i, k)] * sc[k] / sc[i]);
    let mono = if symmetric { &m * &m } else { m.clone() };
    Ok(test_of_matrix(kind, &m, &mono))
}

/// The located orbit where the symmetric orbit of `sys` (stable at `seed_gap_m`) first loses
/// stability, continuing in the gap toward `to_m`, with the event there (`None` when it stays
/// stable or the event has no curve kind).
fn first_loss(
    sys: &System,
    seed: &PeriodicOrbit,
    seed_gap_m: f64,
    to_m: f64,
) -> Result<Option<(PeriodicOrbit, CurveKind)>, SimError> {
    let s = super::continuation::ContinuationSettings {
        max_points: 3000,
        switch_branches: false,
        ..Default::default()
    };
    let _ = sys;
    let b = super::continuation::continue_orbit(
        seed,
        Axis::GapM,
        seed_gap_m,
        to_m,
        &super::ExactJacobian,
        &s,
    )?;
    Ok(b.points
        .iter()
        .find(|p| !p.orbit.stable())
        .and_then(|p| Some((p.orbit.clone(), CurveKind::of_event(p.event?)?))))
}

/// The stability boundary of the symmetric two-impact orbit of `base` (its ratio and gap are
/// ignored) in the settings' box: at each seed ratio, the most stable symmetric orbit on the
/// grid `gaps_m`, the one-parameter continuation in the gap to where it loses stability on each
/// side, and from each such point not already on a curve of its kind, the two-parameter curve
/// ([`continue_curve`]). A curve point is on the boundary when every other multiplier is inside
/// the unit circle ([`on_boundary`]).
pub fn stability_boundary(
    base: &System,
    seed_ratios: &[f64],
    gaps_m: &[f64],
    settings: &Curve2Settings,
) -> Result<Vec<Curve>, SimError> {
    check_settings(settings)?;
    let mut curves: Vec<Curve> = Vec::new();
    for &r in seed_ratios {
        let at = |g: f64| -> Option<PeriodicOrbit> {
            let mut s = *base;
            Axis::FreqRatio.apply(&mut s, r).ok()?;
            Axis::GapM.apply(&mut s, g).ok()?;
            super::region::symmetric_orbit_at(&s, &super::ExactJacobian)
        };
        let best = gaps_m
            .iter()
            .filter_map(|&g| at(g).map(|o| (g, o)))
            .min_by(|a, b| {
                a.1.max_abs_multiplier()
                    .total_cmp(&b.1.max_abs_multiplier())
            });
        let Some((g, seed)) = best else { continue };
        if !seed.stable() {
            continue;
        }
        let sys = seed.section.system;
        for to in [gaps_m[0], gaps_m[gaps_m.len() - 1]] {
            let Some((o, kind)) = first_loss(&sys, &seed, g, to)? else {
                continue;
            };
            let (ro, go) = (ratio_of(&o), gap_of(&o));
            // Already on a curve of its kind: the curve's gap at this ratio (linear between the
            // two points around it) within 0.2 gap units.
            let known = curves.iter().any(|c| {
                c.kind == kind
                    && c.points.windows(2).any(|w| {
                        let (p, q) = (&w[0], &w[1]);
                        let (a, b) = (p.ratio.min(q.ratio), p.ratio.max(q.ratio));
                        if !(a..=b).contains(&ro) {
                            return false;
                        }
                        let f = if b > a {
                            (ro - p.ratio) / (q.ratio - p.ratio)
                        } else {
                            0.0
                        };
                        let g = p.gap_m + f * (q.gap_m - p.gap_m);
                        ((g - go) / GAP_UNIT_M).abs() < 0.2
                    })
            });
            if known {
                continue;
            }
            if let Ok(c) = continue_curve(&o, kind, settings) {
                curves.push(c);
            }
        }
    }
    Ok(curves)
}

/// A curve point on the edge of stability: no multiplier but the critical one(s) outside the
/// unit circle (largest `|λ|` within 1e-6 of 1).
pub fn on_boundary<F: Flow>(p: &CurvePoint<F>) -> bool {
    p.orbit.max_abs_multiplier() < 1.0 + 1e-6
}

fn ratio_of(o: &PeriodicOrbit) -> f64 {
    super::continuation::param_of(&o.section.system, Axis::FreqRatio)
}

fn gap_of(o: &PeriodicOrbit) -> f64 {
    super::continuation::param_of(&o.section.system, Axis::GapM)
}

/// The best gap of the symmetric orbit at one ratio inside its stability interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BestGap {
    /// The gap with the smallest orbit RMS in `[lo, hi]`, m.
    pub gap_m: f64,
    /// The orbit's RMS there, m.
    pub rms_m: f64,
    /// Distance to the nearer end of the interval, m.
    pub margin_m: f64,
    /// Whether the nearer end is the lower one.
    pub nearer_lower: bool,
}

/// The gap in `[lo_m, hi_m]` (a stability interval of the symmetric orbit of `sys`, its gap
/// ignored) where the stable symmetric orbit's RMS is smallest: the RMS at `samples` evenly
/// spaced gaps (Newton from the analytic orbit; a sample without a stable one is skipped), then golden-section search between the best sample's
/// neighbours (to 1e-12 m). `None` when no sample has a symmetric orbit.
pub fn best_gap(sys: &System, lo_m: f64, hi_m: f64, samples: usize) -> Option<BestGap> {
    let rms = |g: f64| -> Option<f64> {
        let mut s = *sys;
        Axis::GapM.apply(&mut s, g).ok()?;
        // The stable orbit only (another symmetric orbit may coexist, e.g. near a fold).
        super::region::symmetric_orbit_at(&s, &super::ExactJacobian)
            .filter(|o| o.stable())
            .map(|o| o.rms_m)
    };
    let n = samples.max(3);
    let gs: Vec<f64> = (0..n)
        .map(|i| lo_m + (hi_m - lo_m) * i as f64 / (n - 1) as f64)
        .collect();
    let vals: Vec<Option<f64>> = gs.iter().map(|&g| rms(g)).collect();
    let (ib, _) = vals
        .iter()
        .enumerate()
        .filter_map(|(i, v)| v.map(|v| (i, v)))
        .min_by(|a, b| a.1.total_cmp(&b.1))?;
    let (mut a, mut b) = (gs[ib.saturating_sub(1)], gs[(ib + 1).min(n - 1)]);
    let f = |g: f64| rms(g).unwrap_or(f64::INFINITY);
    let phi = 0.5 * (5f64.sqrt() - 1.0);
    let (mut x1, mut x2) = (b - phi * (b - a), a + phi * (b - a));
    let (mut f1, mut f2) = (f(x1), f(x2));
    while b - a > 1e-12 {
        if f1 <= f2 {
            b = x2;
            (x2, f2) = (x1, f1);
            x1 = b - phi * (b - a);
            f1 = f(x1);
        } else {
            a = x1;
            (x1, f1) = (x2, f2);
            x2 = a + phi * (b - a);
            f2 = f(x2);
        }
    }
    let (mut g, mut r) = if f1 <= f2 { (x1, f1) } else { (x2, f2) };
    // The golden search stays within the sample's bracket; keep the sample if it is better.
    let rb = vals[ib].unwrap_or(f64::INFINITY);
    if rb < r {
        (g, r) = (gs[ib], rb);
    }
    if !r.is_finite() {
        return None;
    }
    let (dl, dh) = (g - lo_m, hi_m - g);
    Some(BestGap {
        gap_m: g,
        rms_m: r,
        margin_m: dl.min(dh),
        nearer_lower: dl <= dh,
    })
}

/// The steady-state RMS `F₀/(√2·√((K − MΩ²)² + (CΩ)²))` of a lumped bar without a ball (the
/// solid reference of the design maps), at the forcing of `sys`.
pub fn linear_rms_m(sys: &System) -> Option<f64> {
    let b = sys.lumped_bar()?;
    let w = sys.omega_rad_s();
    let c = 2.0 * b.damping_ratio * (b.stiffness_n_per_m * b.mass_kg).sqrt();
    let d = (b.stiffness_n_per_m - b.mass_kg * w * w).hypot(c * w);
    Some(sys.forcing.amplitude_n / (std::f64::consts::SQRT_2 * d))
}
