//! Periodic orbits and the Lyapunov spectrum of the bar that bends in two planes, where its
//! planes decouple: frictionless walls and the bar's principal axes along and across the hole
//! ([`decoupled`]).
//!
//! There the two-plane motion is exactly two one-plane motions
//! ([`plane_system`]): along the hole, the ball between the plugs with the force's component
//! and gravity's along the hole; across it, the ball against the hole's wall with the force's
//! component there and gravity's across the hole as a body force. So a period-`k` orbit of the
//! two-plane bar is a period-`k` orbit of each plane, its Floquet multipliers are the union of
//! the planes' (each computed with the saltation matrices of its impacts, rests, lift-offs and
//! landings, [`crate::analysis::variational`]), and its Lyapunov spectrum the union of the
//! planes' spectra. The ball's spin is a neutral direction on frictionless walls (nothing
//! acts on it, nothing reads it): multiplier 1, exponent 0, reported apart from the planes.
//!
//! The orbit's RMS along the force, in each direction and in total is not the planes' RMS
//! added: it holds the cross term `∫u_a u_n`. It comes from a run of the two-plane exact solver
//! over one orbit period from the orbit's state, which must come back to that state (its return
//! gap is reported).
//!
//! With friction on the walls the planes couple through the normal force, and the saltation
//! of sliding, rolling, sticking and corner contacts is not derived: orbits and the spectrum
//! are refused there, naming why.

use super::grid::Axis;
use super::lyapunov_spectrum::{
    lyapunov_spectrum, lyapunov_spectrum_modal, SpectrumParams, SpectrumResult,
};
use super::orbit::continuation::{continue_orbit, Branch, ContinuationSettings};
use super::orbit::modal::{modal_orbit_settled, modal_scales, ModalPeriodicOrbit, ModalSection};
use super::orbit::{find_orbit, scales, starting_guess, to_vector, MapJacobian};
use super::orbit::{Flow, Orbit, Section};
use super::orbit::{NewtonSettings, PeriodicOrbit, Start};
use crate::error::{ParamError, SimError};
use crate::params::two_plane::TwoPlaneSystem;
use crate::params::{BarModel, Frequency, RunSettings};
use crate::solver::exact::modal::ModalExact;
use crate::solver::two_plane_exact::{
    decoupled, hole_axes, plane_start, plane_system, TwoPlaneExact,
};
use crate::solver::two_plane_rk4::{Sampling, TwoPlaneSample, TwoPlaneStart, TwoPlaneSummary};
use crate::solver::{Exact, Solver};
use crate::structure::{ModalState, ModalSystem, Point};

/// Why orbits and the spectrum of a two-plane bar whose planes do not decouple are refused
/// ([`decoupled`] gives the particular reason).
pub const TWO_PLANE_ORBIT_SCOPE: &str = "periodic orbits and the Lyapunov spectrum of the bar \
that bends in two planes need its planes to decouple: frictionless walls, a radial clearance and \
the bar's principal axes along and across the hole; with friction on the walls the saltation of \
sliding, rolling, sticking and corner contacts is not derived";

/// Refuse orbits and the spectrum of `sys` where they are not built.
fn check(sys: &TwoPlaneSystem) -> Result<(), SimError> {
    if decoupled(sys).is_err() {
        return Err(SimError::Unsupported(TWO_PLANE_ORBIT_SCOPE));
    }
    Ok(())
}

/// A periodic orbit of a decoupled two-plane bar, on either bar (`F`: the lumped bar's
/// [`Section`] or a round bar of modes' [`ModalSection`]).
#[derive(Debug, Clone)]
pub struct TwoPlaneOrbit<F: Flow = Section> {
    /// The orbit of each plane's one-plane system: `[along the hole, across it]`, each at its
    /// own section time.
    pub planes: [Orbit<F>; 2],
    /// The two-plane state on the orbit at [`start_t_s`](Self::start_t_s) (the later of the
    /// planes' section times); on a round bar its public picture (the response point, the ball
    /// relative to the cavity).
    pub start: TwoPlaneStart,
    /// Its time.
    pub start_t_s: f64,
    /// A run of the two-plane exact solver over one orbit period from there: the RMS over the
    /// orbit along the force, per direction and in total, impacts per wall.
    pub summary: TwoPlaneSummary,
    /// `max |x(t + kT) − x(t)|` of that run over each plane's `(u, u̇, w, ẇ)`, in the plane's
    /// scaled units: how closely the two-plane run repeats the orbit.
    pub return_gap: f64,
}

impl<F: Flow> TwoPlaneOrbit<F> {
    /// Floquet multipliers of both planes, largest modulus first (the spin's neutral 1 left
    /// out).
    pub fn multipliers(&self) -> Vec<num_complex::Complex64> {
        let mut m: Vec<_> = self
            .planes
            .iter()
            .flat_map(|o| o.multipliers.iter().copied())
            .collect();
        m.sort_by(|a, b| b.norm().total_cmp(&a.norm()));
        m
    }

    /// Stable when both planes are.
    pub fn stable(&self) -> bool {
        self.planes.iter().all(|o| o.stable())
    }

    /// Impacts over the orbit's period, both planes.
    pub fn impacts_per_period(&self) -> u32 {
        self.planes.iter().map(|o| o.impacts_per_period).sum()
    }
}

/// A two-plane orbit of the bar the system has.
#[derive(Debug, Clone)]
pub enum TwoPlaneOrbitOf {
    /// A lumped bar's.
    Lumped(Box<TwoPlaneOrbit<Section>>),
    /// A round bar of modes'.
    Round(Box<TwoPlaneOrbit<ModalSection>>),
}

impl TwoPlaneOrbitOf {
    /// The summary of the two-plane run over the orbit.
    pub fn summary(&self) -> &TwoPlaneSummary {
        match self {
            TwoPlaneOrbitOf::Lumped(o) => &o.summary,
            TwoPlaneOrbitOf::Round(o) => &o.summary,
        }
    }
}

/// One plane at the common time: its public `(u, u̇, w, ẇ)` and their scales.
struct PlanePoint {
    x: [f64; 4],
    scales: [f64; 4],
}

/// The period-`periods` orbit that the run from `start` settles on over `settle_s` in each
/// plane, found by Newton's method (with `jac` on a lumped bar, the modal variational flow on a
/// round bar of modes), and the two-plane run over it.
pub fn two_plane_orbit(
    sys: &TwoPlaneSystem,
    periods: u32,
    start: &TwoPlaneStart,
    settle_s: f64,
    jac: &dyn MapJacobian,
) -> Result<TwoPlaneOrbitOf, SimError> {
    sys.validate()?;
    check(sys)?;
    let psys = [plane_system(sys, 0)?, plane_system(sys, 1)?];
    let inits = [0, 1].map(|axis| plane_start(sys, start, axis, 0.0));
    if sys.bar.lumped().is_some() {
        let mut planes = Vec::with_capacity(2);
        for axis in 0..2 {
            let init = inits[axis];
            let (sec, x0) =
                starting_guess(&psys[axis], periods, &Start::Settled { init, settle_s })?;
            planes.push(find_orbit(&sec, &x0, jac, &NewtonSettings::default())?);
        }
        let planes: [PeriodicOrbit; 2] = planes.try_into().expect("two planes");
        let t0 = planes[0].section.t0_s.max(planes[1].section.t0_s);
        let mut pts = Vec::with_capacity(2);
        for o in &planes {
            let s = if o.state.t_s >= t0 {
                o.state
            } else {
                Exact::default()
                    .run(&o.section.system, &o.state, t0, &mut ())?
                    .final_state
            };
            pts.push(PlanePoint {
                x: to_vector(&s),
                scales: scales(&o.section.system),
            });
        }
        let pts: [PlanePoint; 2] = pts.try_into().ok().expect("two planes");
        let (start2, summary, gap) = over_one_period(sys, &pts, None, t0, periods)?;
        return Ok(TwoPlaneOrbitOf::Lumped(Box::new(TwoPlaneOrbit {
            planes,
            start: start2,
            start_t_s: t0,
            summary,
            return_gap: gap,
        })));
    }
    let msys = [
        ModalSystem::from_system(&psys[0])?,
        ModalSystem::from_system(&psys[1])?,
    ];
    let mut planes = Vec::with_capacity(2);
    for axis in 0..2 {
        let init = ModalState::from_public(&msys[axis].model, &inits[axis])?;
        planes.push(modal_orbit_settled(&msys[axis], periods, &init, settle_s)?);
    }
    let planes: [ModalPeriodicOrbit; 2] = planes.try_into().expect("two planes");
    let t0 = planes[0].section.t0_s().max(planes[1].section.t0_s());
    let mut pts = Vec::with_capacity(2);
    let mut modal = Vec::with_capacity(2);
    for (axis, o) in planes.iter().enumerate() {
        let s = if o.state.t_s >= t0 {
            o.state
        } else {
            ModalExact::default()
                .run(&msys[axis], &o.state, t0, &mut ())?
                .final_state
        };
        let model = &msys[axis].model;
        let sc = modal_scales(&msys[axis]);
        let n = msys[axis].n_modes();
        pts.push(PlanePoint {
            x: [
                s.u_at(model, Point::Response),
                s.du_at(model, Point::Response),
                s.w_m(model),
                s.dw_m_s(model),
            ],
            scales: [sc[0], sc[n], sc[2 * n], sc[2 * n + 1]],
        });
        modal.push(s);
    }
    let pts: [PlanePoint; 2] = pts.try_into().ok().expect("two planes");
    let modal: [ModalState; 2] = modal.try_into().expect("two planes");
    let (start2, summary, gap) = over_one_period(sys, &pts, Some(&modal), t0, periods)?;
    Ok(TwoPlaneOrbitOf::Round(Box::new(TwoPlaneOrbit {
        planes,
        start: start2,
        start_t_s: t0,
        summary,
        return_gap: gap,
    })))
}

/// The two-plane run over one orbit period from the planes' points at `t0` (from their modal
/// states on a round bar): the start's public picture, the summary and the return gap (the
/// run's samples at `t0` and `t0 + kT` compared plane by plane, in each plane's scales).
fn over_one_period(
    sys: &TwoPlaneSystem,
    pts: &[PlanePoint; 2],
    modal: Option<&[ModalState; 2]>,
    t0: f64,
    periods: u32,
) -> Result<(TwoPlaneStart, TwoPlaneSummary, f64), SimError> {
    let axes = hole_axes(sys);
    let comb = |i: usize| [0, 1].map(|c| pts[0].x[i] * axes[0][c] + pts[1].x[i] * axes[1][c]);
    let start = TwoPlaneStart {
        u_m: comb(0),
        du_m_s: comb(1),
        w_hole_m: [pts[0].x[2], pts[1].x[2]],
        dw_hole_m_s: [pts[0].x[3], pts[1].x[3]],
        spin_rad_s: 0.0,
    };
    let period_s = periods as f64 * 2.0 * std::f64::consts::PI / sys.omega_rad_s();
    let settings = RunSettings {
        duration_s: period_s,
        dt_s: 1e-6,
        rms_fraction: 1.0,
    };
    let mut samples: Vec<TwoPlaneSample> = Vec::with_capacity(2);
    let mut on_sample = |s: &TwoPlaneSample| samples.push(*s);
    let sampling = Some(Sampling {
        start_s: t0,
        interval_s: period_s,
        on_sample: &mut on_sample,
    });
    let solver = TwoPlaneExact::default();
    let summary = match modal {
        None => solver.run_from(sys, &start, t0, &settings, &mut |_| {}, sampling)?,
        Some(m) => solver.run_from_modal(sys, &start, m, t0, &settings, &mut |_| {}, sampling)?,
    };
    let gap = match samples.as_slice() {
        [a, b, ..] => (0..2)
            .map(|axis| {
                let (x, y) = (
                    to_vector(&plane_start(sys, &a.state, axis, t0)),
                    to_vector(&plane_start(sys, &b.state, axis, t0)),
                );
                (0..4)
                    .map(|i| ((x[i] - y[i]) / pts[axis].scales[i]).abs())
                    .fold(0.0, f64::max)
            })
            .fold(0.0, f64::max),
        _ => f64::INFINITY,
    };
    Ok((start, summary, gap))
}

/// The Lyapunov spectrum of a decoupled two-plane bar's run from `start`: each plane's spectrum
/// over the same window (`[along the hole, across it]`). The spin adds a neutral exponent 0.
pub fn two_plane_lyapunov_spectrum(
    sys: &TwoPlaneSystem,
    start: &TwoPlaneStart,
    params: &SpectrumParams,
) -> Result<[SpectrumResult; 2], SimError> {
    sys.validate()?;
    check(sys)?;
    let mut out = Vec::with_capacity(2);
    for axis in 0..2 {
        let psys = plane_system(sys, axis)?;
        let init = plane_start(sys, start, axis, 0.0);
        out.push(match &psys.bar {
            BarModel::Lumped(_) => lyapunov_spectrum(&psys, &init, &Exact::default(), params)?,
            BarModel::Modal(model) => lyapunov_spectrum_modal(
                &ModalSystem::from_system(&psys)?,
                &ModalState::from_public(model, &init)?,
                params,
            )?,
        });
    }
    Ok(out.try_into().expect("two planes"))
}

/// One plane of a two-plane continuation.
#[derive(Debug, Clone)]
pub enum PlaneBranch {
    /// The plane's orbits followed in the parameter; `scale` turns the branch's parameter
    /// values (the plane's own frequency ratio when the ratio is followed) into the two-plane
    /// scenario's.
    Followed {
        /// The branch.
        branch: Branch,
        /// Two-plane parameter per branch parameter.
        scale: f64,
    },
    /// The parameter does not act on this plane (the axial gap across the hole): its one orbit.
    Fixed(Box<PeriodicOrbit>),
}

/// The parameters a two-plane continuation follows: the frequency ratio and the restitution
/// (both planes) and the axial gap (the plane along the hole).
pub const TWO_PLANE_CONTINUATION_AXES: [Axis; 3] = [Axis::FreqRatio, Axis::GapM, Axis::Restitution];

/// Follow the period-`periods` orbit that the run from `start` settles on over `settle_s`, in
/// each plane, from `from` to `to` of `axis` (two-plane units: the ratio refers to the bar's
/// lower principal frequency). Where the planes decouple the two-plane orbit at a parameter
/// value is the pair of the planes' orbits there, stable where both are.
#[allow(clippy::too_many_arguments)]
pub fn two_plane_branches(
    sys: &TwoPlaneSystem,
    start: &TwoPlaneStart,
    axis: Axis,
    from: f64,
    to: f64,
    periods: u32,
    settle_s: f64,
    jac: &dyn MapJacobian,
    settings: &ContinuationSettings,
) -> Result<[PlaneBranch; 2], SimError> {
    if !TWO_PLANE_CONTINUATION_AXES.contains(&axis) {
        return Err(ParamError::OutOfRange {
            field: "followed parameter of a two-plane continuation",
            value: f64::NAN,
            allowed: "ratio, gap-mm (the axial gap) or restitution (friction on the walls couples the planes)",
        }
        .into());
    }
    let mut at_from = *sys;
    match axis {
        Axis::FreqRatio => at_from.forcing.frequency = Frequency::Ratio(from),
        Axis::GapM => at_from.hole.axial_gap_m = from,
        _ => at_from.ball.restitution = from,
    }
    at_from.validate()?;
    check(&at_from)?;
    if at_from.bar.lumped().is_none() {
        return Err(SimError::Unsupported(
            "continuation of a bar of modes in two planes is not built (its orbit, `orbit`, \
             and the lumped bar's continuation are)",
        ));
    }
    let omega1 = at_from.bar.omega1_rad_s();
    let mut out = Vec::with_capacity(2);
    for plane in 0..2 {
        let mut psys = plane_system(&at_from, plane)?;
        // The plane's own ratio is Ω over its own first frequency; the continuation follows
        // the ratio, so the plane's forcing is given as one.
        let scale = match axis {
            Axis::FreqRatio => {
                let s = psys.omega1_rad_s() / omega1;
                psys.forcing.frequency = Frequency::Ratio(from / s);
                s
            }
            _ => 1.0,
        };
        let init = plane_start(&at_from, start, plane, 0.0);
        let (sec, x0) = starting_guess(&psys, periods, &Start::Settled { init, settle_s })?;
        let orbit = find_orbit(&sec, &x0, jac, &NewtonSettings::default())?;
        if axis == Axis::GapM && plane == 1 {
            out.push(PlaneBranch::Fixed(Box::new(orbit)));
            continue;
        }
        if orbit.impacts_per_period == 0 {
            return Err(SimError::Unsupported(if plane == 0 {
                "at the start of the interval the ball floats along the hole without an impact: \
                 its orbits form a continuum (a multiplier 1) that no continuation can follow; \
                 start where it impacts (another ratio, a smaller axial gap or another member)"
            } else {
                "at the start of the interval the ball floats across the hole without an impact: \
                 its orbits form a continuum (a multiplier 1) that no continuation can follow; \
                 start where it impacts (another ratio, a tighter hole or another member)"
            }));
        }
        let branch = continue_orbit(&orbit, axis, from / scale, to / scale, jac, settings)?;
        out.push(PlaneBranch::Followed { branch, scale });
    }
    Ok(out.try_into().expect("two planes"))
}
