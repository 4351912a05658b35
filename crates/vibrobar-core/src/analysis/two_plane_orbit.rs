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
use super::lyapunov_spectrum::{lyapunov_spectrum, SpectrumParams, SpectrumResult};
use super::orbit::continuation::{continue_orbit, Branch, ContinuationSettings};
use super::orbit::{find_orbit, scales, starting_guess, to_vector, MapJacobian};
use super::orbit::{NewtonSettings, PeriodicOrbit, Start};
use super::two_plane::TwoPlaneMethod;
use crate::error::{ParamError, SimError};
use crate::params::two_plane::TwoPlaneSystem;
use crate::params::{Frequency, RunSettings, State};
use crate::solver::two_plane_exact::{decoupled, hole_axes, plane_start, plane_system};
use crate::solver::two_plane_rk4::{Sampling, TwoPlaneSample, TwoPlaneStart, TwoPlaneSummary};
use crate::solver::{Exact, Solver};

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
    if sys.bar.lumped().is_none() {
        return Err(SimError::Unsupported(
            "periodic orbits and the Lyapunov spectrum of a round bar of modes in two planes \
             are not built (the lumped bar's are); the largest exponent runs",
        ));
    }
    Ok(())
}

/// A periodic orbit of a decoupled two-plane bar.
#[derive(Debug, Clone)]
pub struct TwoPlaneOrbit {
    /// The orbit of each plane's one-plane system: `[along the hole, across it]`, each at its
    /// own section time.
    pub planes: [PeriodicOrbit; 2],
    /// The two-plane state on the orbit at [`start_t_s`](Self::start_t_s) (the later of the
    /// planes' section times).
    pub start: TwoPlaneStart,
    /// Its time.
    pub start_t_s: f64,
    /// A run of the two-plane exact solver over one orbit period from `start`: the RMS over the
    /// orbit along the force, per direction and in total, impacts per wall.
    pub summary: TwoPlaneSummary,
    /// `max |x(t + kT) − x(t)|` of that run over the plane states, in the planes' scaled units:
    /// how closely the two-plane run repeats the orbit.
    pub return_gap: f64,
}

impl TwoPlaneOrbit {
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

/// The period-`periods` orbit that the run from `start` settles on over `settle_s` in each
/// plane, found by Newton's method with `jac`, and the two-plane run over it.
pub fn two_plane_orbit(
    sys: &TwoPlaneSystem,
    periods: u32,
    start: &TwoPlaneStart,
    settle_s: f64,
    jac: &dyn MapJacobian,
) -> Result<TwoPlaneOrbit, SimError> {
    sys.validate()?;
    check(sys)?;
    let mut planes = Vec::with_capacity(2);
    for axis in 0..2 {
        let psys = plane_system(sys, axis)?;
        let init = plane_start(sys, start, axis, 0.0);
        let (sec, x0) = starting_guess(&psys, periods, &Start::Settled { init, settle_s })?;
        planes.push(find_orbit(&sec, &x0, jac, &NewtonSettings::default())?);
    }
    let planes: [PeriodicOrbit; 2] = planes.try_into().expect("two planes");
    // Both planes at the later section time (each orbit is kT-periodic, the sections lie in
    // [0, T)).
    let t0 = planes[0].section.t0_s.max(planes[1].section.t0_s);
    let at: Vec<State> = planes
        .iter()
        .map(|o| {
            if o.state.t_s >= t0 {
                Ok(o.state)
            } else {
                Ok(Exact::default()
                    .run(&o.section.system, &o.state, t0, &mut ())?
                    .final_state)
            }
        })
        .collect::<Result<_, SimError>>()?;
    let axes = hole_axes(sys);
    let comb =
        |f: &dyn Fn(&State) -> f64| [0, 1].map(|c| f(&at[0]) * axes[0][c] + f(&at[1]) * axes[1][c]);
    let start2 = TwoPlaneStart {
        u_m: comb(&|s| s.u_m),
        du_m_s: comb(&|s| s.du_m_s),
        w_hole_m: [at[0].w_m(), at[1].w_m()],
        dw_hole_m_s: [at[0].dw_m_s(), at[1].dw_m_s()],
        spin_rad_s: 0.0,
    };
    let period_s = periods as f64 * planes[0].section.period_s();
    let settings = RunSettings {
        duration_s: period_s,
        dt_s: 1e-6,
        rms_fraction: 1.0,
    };
    let mut end: Option<TwoPlaneSample> = None;
    let mut on_sample = |s: &TwoPlaneSample| end = Some(*s);
    let summary = TwoPlaneMethod::Exact.run_from(
        sys,
        &start2,
        t0,
        &settings,
        &mut |_| {},
        Some(Sampling {
            start_s: t0 + period_s,
            interval_s: period_s,
            on_sample: &mut on_sample,
        }),
    )?;
    let return_gap = match end {
        Some(e) => (0..2)
            .map(|axis| {
                let a = to_vector(&plane_start(sys, &start2, axis, t0));
                let b = to_vector(&plane_start(sys, &e.state, axis, t0));
                let sc = scales(&planes[axis].section.system);
                (0..4)
                    .map(|i| ((a[i] - b[i]) / sc[i]).abs())
                    .fold(0.0, f64::max)
            })
            .fold(0.0, f64::max),
        None => f64::INFINITY,
    };
    Ok(TwoPlaneOrbit {
        planes,
        start: start2,
        start_t_s: t0,
        summary,
        return_gap,
    })
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
        out.push(lyapunov_spectrum(
            &psys,
            &plane_start(sys, start, axis, 0.0),
            &Exact::default(),
            params,
        )?);
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
