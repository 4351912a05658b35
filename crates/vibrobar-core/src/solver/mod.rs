//! The solver interface: one trait that every solver implements, and the observer protocol through
//! which analyses see a run.
//!
//! A solver reports a run as a sequence of smooth [`Segment`]s separated by [`Event`]s (impacts,
//! friction switches, …). Analyses are [`Observer`]s: they never know which solver produced the
//! segments, so every analysis works with every solver.

pub mod dopri5;
pub mod exact;
pub mod rk4;
pub mod two_plane_exact;
pub mod two_plane_rk4;

/// The N-mode bar's RK4 ([`rk4::modal`]), under the path it has always had.
pub use rk4::modal as modal_rk4;

pub use exact::Exact;
pub use rk4::Rk4;

use crate::error::SimError;
use crate::params::{RunSettings, State, System};
use serde::{Deserialize, Serialize};

/// Which wall of the cavity: `Plus` is at `w = +l_g`, `Minus` at `w = −l_g`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Wall {
    /// `w = +l_g`.
    Plus,
    /// `w = −l_g`.
    Minus,
}

impl Wall {
    /// `+1` or `−1`.
    pub fn sign(self) -> f64 {
        match self {
            Wall::Plus => 1.0,
            Wall::Minus => -1.0,
        }
    }
}

/// What happened at an event.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum EventKind {
    /// Ball hit a wall with pre-impact relative velocity `dw_m_s` (Eqs. 4–5 applied).
    Impact {
        /// Wall hit.
        wall: Wall,
        /// `ẇ−`.
        dw_m_s: f64,
        /// Kinetic energy lost.
        energy_loss_j: f64,
    },
    /// `ẇ` changed sign; the sliding friction reversed.
    FrictionSwitch,
    /// Ball started to stick to the bar (`coulomb`).
    Stick,
    /// Ball started to slide again.
    Unstick,
    /// A chatter sequence at a wall was summed to its accumulation point; the ball now rides
    /// against the wall. `energy_loss_j` is the kinetic energy lost by the remaining impacts.
    ChatterLimit {
        /// Wall.
        wall: Wall,
        /// Impacts extrapolated (infinitely many in theory; this is the loss they carry).
        energy_loss_j: f64,
    },
    /// Contact force at a wall reached zero; the ball leaves the wall.
    ContactRelease {
        /// Wall.
        wall: Wall,
    },
}

/// A discrete event in a run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Event {
    /// Time of the event.
    pub t_s: f64,
    /// Kind.
    pub kind: EventKind,
    /// State just before.
    pub before: State,
    /// State just after.
    pub after: State,
}

/// How the ball moves during a segment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Mode {
    /// No ball at all (solid bar).
    NoBall,
    /// Ball moves freely relative to the bar.
    Free,
    /// Ball sticks to the bar away from the walls (`coulomb`).
    Stick,
    /// Ball rides pressed against a wall.
    Contact(Wall),
}

/// The cut at one instant of a cutting run.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct CutSample {
    /// Chip thickness `h = h0 + c_chip (s(t − τ) − u_tip)` (≤ 0 out of the cut).
    pub chip_thickness_m: f64,
    /// The tool cuts (`h > 0`).
    pub in_cut: bool,
    /// Force of the cut on the bar at the force point, `c_force F(h)` (0 out of the cut).
    pub cutting_force_n: f64,
}

/// Integrals over part of a segment, the raw material of RMS and the energy audit.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct SegmentIntegrals {
    /// `∫ u² dt`.
    pub u2_m2_s: f64,
    /// Work of the external force on the bar, `∫ F(t) u̇ dt`.
    pub forcing_work_j: f64,
    /// Viscous loss, `∫ C u̇² dt`.
    pub viscous_loss_j: f64,
    /// Work of the friction force on the bar–ball system, `∫ F_ball ẇ dt` (positive = energy in).
    pub friction_work_j: f64,
}

impl std::ops::AddAssign for SegmentIntegrals {
    fn add_assign(&mut self, o: Self) {
        self.u2_m2_s += o.u2_m2_s;
        self.forcing_work_j += o.forcing_work_j;
        self.viscous_loss_j += o.viscous_loss_j;
        self.friction_work_j += o.friction_work_j;
    }
}

/// A smooth piece of the motion between two events.
pub trait Segment {
    /// Start time.
    fn t_start_s(&self) -> f64;
    /// End time.
    fn t_end_s(&self) -> f64;
    /// Mode during the segment.
    fn mode(&self) -> Mode;
    /// State at `t` in `[t_start, t_end]`.
    fn state_at(&self, t_s: f64) -> State;
    /// `∫ u² dt` over `[a, b] ⊆ [t_start, t_end]`: the hot path of RMS, kept separate.
    fn integral_u2(&self, a_s: f64, b_s: f64) -> f64;
    /// All integrals over `[a, b] ⊆ [t_start, t_end]`.
    fn integrals(&self, a_s: f64, b_s: f64) -> SegmentIntegrals;
    /// Mechanical energy at `t` in `[t_start, t_end]`: the bar's (every mode's kinetic and
    /// strain energy; `½Mu̇² + ½Ku²` for the lumped bar) plus the ball's `½m_d v̇²`. The public
    /// [`State`] cannot give it for a modal bar, so the energy audit asks the segment.
    fn mechanical_energy_j(&self, t_s: f64) -> f64;
    /// The cut at `t` of a cutting run ([`crate::excitation::Cutting`]); `None` without a cut.
    fn cutting_at(&self, _t_s: f64) -> Option<CutSample> {
        None
    }
    /// Work of the cutting force on the bar over `[a, b]`, `∫ F_cut u̇_tip dt` (0 without a
    /// cut); [`SegmentIntegrals::forcing_work_j`] holds the harmonic force's work only.
    fn cutting_work_j(&self, _a_s: f64, _b_s: f64) -> f64 {
        0.0
    }
    /// The bar's acceleration `ü` at `t` in `[t_start, t_end]` where the segment holds it in
    /// closed form (the lumped bar's exact segments); `None` elsewhere. The cutting run's
    /// surface history stores it at its knots (a quintic Hermite between them).
    fn acceleration_at(&self, _t_s: f64) -> Option<f64> {
        None
    }
    /// The compliant (`hertz`) contact phase this segment is a step of; `None` for every other
    /// segment. What the variational layer needs to linearise the phase's vector field.
    fn compliant_contact(&self) -> Option<CompliantContact> {
        None
    }
    /// The bar's displacement on this segment as one exponential sum `x`, with
    /// `u(t) = x(t − t_start)`, where the segment holds it so (the lumped bar's exact segments
    /// outside a cut); `None` elsewhere. What lets two runs integrate the product of their
    /// displacements in closed form.
    fn displacement_sum(&self) -> Option<exact::lumped::expsum::ExpSum> {
        None
    }
}

/// The constants of one step of a compliant contact phase ([`exact::hertz`]): the law, the
/// wall, the reference speed fixed at the touch and the friction state. The penetration and its
/// rate are `δ = s·w − l_g`, `δ̇ = s·ẇ` of [`Segment::state_at`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompliantContact {
    /// `s = ±1`, the wall.
    pub wall_sign: f64,
    /// `s·ẇ` at the touch (≥ 0).
    pub approach_m_s: f64,
    /// The law's `δ̇₀`: the approach speed, or the floor [`exact::hertz::APPROACH_FLOOR_REL`]
    /// `· l_g · max(Ω, ω_d)` when the approach is slower.
    pub reference_speed_m_s: f64,
    /// Sliding friction force on the ball during this step (0 when stuck or frictionless).
    pub ball_friction_n: f64,
    /// The ball is stuck to the wall by friction (`δ̇ = 0`, `δ` fixed).
    pub stuck: bool,
    /// The law.
    pub law: crate::damper::contact::Hertz,
}

/// Sees a run as it is computed. Every method defaults to a no-op.
pub trait Observer {
    /// A smooth segment was completed.
    fn segment(&mut self, _seg: &dyn Segment) {}
    /// An event happened (after the segment that ends at it).
    fn event(&mut self, _ev: &Event) {}
}

/// Does nothing.
impl Observer for () {}

/// Feeds two observers.
impl<A: Observer, B: Observer> Observer for (A, B) {
    fn segment(&mut self, seg: &dyn Segment) {
        self.0.segment(seg);
        self.1.segment(seg);
    }
    fn event(&mut self, ev: &Event) {
        self.0.event(ev);
        self.1.event(ev);
    }
}

/// Feeds any number of observers: `Fanout(&mut [&mut a, &mut b])`.
pub struct Fanout<'a, 'b>(pub &'a mut [&'b mut dyn Observer]);

impl Observer for Fanout<'_, '_> {
    fn segment(&mut self, seg: &dyn Segment) {
        for o in self.0.iter_mut() {
            o.segment(seg);
        }
    }
    fn event(&mut self, ev: &Event) {
        for o in self.0.iter_mut() {
            o.event(ev);
        }
    }
}

/// What a solver says about a finished run.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct RunSummary {
    /// State at the end.
    pub final_state: State,
    /// Impacts over the whole run.
    pub impacts: u64,
    /// All events over the whole run.
    pub events: u64,
    /// Largest `|w| − l_g` seen (penetration into the wall; ≤ 0 when the ball never left).
    pub max_penetration_m: f64,
}

/// Every solver implements this; every analysis is written against it. Solvers are plain
/// settings (`Send + Sync`): one may be shared by threads or moved into one, and a run keeps its
/// own scratch space.
pub trait Solver: Send + Sync {
    /// Short name used in the CLI and in output files (`rk4`, `exact`).
    fn name(&self) -> &'static str;
    /// Integrate `sys` from `init` (at `init.t_s`) until `t_end_s`, reporting to `obs`.
    fn run(
        &self,
        sys: &System,
        init: &State,
        t_end_s: f64,
        obs: &mut dyn Observer,
    ) -> Result<RunSummary, SimError>;
}

/// The solvers that apply only the instantaneous restitution law refuse a `hertz` contact
/// instead of silently running another law.
pub(crate) fn refuse_hertz(
    damper: Option<&crate::params::Damper>,
    why: &'static str,
) -> Result<(), SimError> {
    match damper {
        Some(d) if d.contact.law == crate::params::ContactLaw::Hertz => {
            Err(SimError::Unsupported(why))
        }
        _ => Ok(()),
    }
}

/// A constant body force on the ball along the gap (`damper.gravity_along_gap_m_s2 ≠ 0`) is
/// refused with `why` where it is not supported, instead of being silently ignored.
pub(crate) fn refuse_ball_body_force(
    damper: Option<&crate::params::Damper>,
    why: &'static str,
) -> Result<(), SimError> {
    match damper {
        Some(d) if d.gravity_along_gap_m_s2 != 0.0 => Err(SimError::Unsupported(why)),
        _ => Ok(()),
    }
}

/// The exact solver's refusal of the ball's body force under the `hertz` contact law.
pub(crate) const GRAVITY_ALONG_GAP_HERTZ: &str = "damper.gravity_along_gap_m_s2 ≠ 0 is not supported with contact.law = hertz (the compliant contact phase has no body force on the ball); use contact.law = restitution or set damper.gravity_along_gap_m_s2 = 0";

/// The cutting runs' refusal of the ball's body force.
pub(crate) const GRAVITY_ALONG_GAP_CUTTING: &str = "damper.gravity_along_gap_m_s2 ≠ 0 is not supported in cutting runs; set damper.gravity_along_gap_m_s2 = 0 or run without [cutting]";

/// The exact solver's refusal of the ball's body force under `hertz` (only there: the
/// restitution law supports it).
pub(crate) fn refuse_ball_body_force_hertz(
    damper: Option<&crate::params::Damper>,
) -> Result<(), SimError> {
    match damper {
        Some(d) if d.contact.law == crate::params::ContactLaw::Hertz => {
            refuse_ball_body_force(damper, GRAVITY_ALONG_GAP_HERTZ)
        }
        _ => Ok(()),
    }
}

/// Checks every solver makes before it runs: the system, the initial state, and an end time that
/// is finite and not before the start (a NaN or backward end would otherwise run nothing and
/// return `Ok`, looking like a finished run).
pub fn validate_run(sys: &System, init: &State, t_end_s: f64) -> Result<(), SimError> {
    sys.validate()?;
    init.validate(sys)?;
    check_end_time(init.t_s, t_end_s)?;
    sys.validate_horizon(init.t_s, t_end_s)?;
    Ok(())
}

/// An end time that is finite and not before the start (a NaN or backward end would otherwise
/// run nothing and return `Ok`, looking like a finished run).
fn check_end_time(t0_s: f64, t_end_s: f64) -> Result<(), SimError> {
    crate::params::finite("t_end_s", t_end_s)?;
    if t_end_s < t0_s {
        return Err(crate::error::ParamError::OutOfRange {
            field: "t_end_s",
            value: t_end_s,
            allowed: "[initial.t_s, ∞)",
        }
        .into());
    }
    Ok(())
}

/// The checks of [`validate_run`] for the modal solvers: the system, `hertz` refused with
/// `hertz_why` by a solver without a compliant contact phase (`None`: it has one), the initial
/// state, the end time, and the phase of the fastest of `Ω` and `ω_N` over the run.
pub(crate) fn validate_modal_run(
    sys: &crate::structure::ModalSystem,
    init: &crate::structure::ModalState,
    t_end_s: f64,
    hertz_why: Option<&'static str>,
) -> Result<(), SimError> {
    sys.validate()?;
    if let Some(why) = hertz_why {
        refuse_hertz(sys.damper.as_ref(), why)?;
    }
    init.validate(sys)?;
    check_end_time(init.t_s, t_end_s)?;
    let rate = sys.omega_rad_s().max(sys.omega_max_rad_s());
    crate::limits::check_phase(rate, init.t_s.abs().max(t_end_s.abs()))?;
    Ok(())
}

/// A modal run: the modal state at `t_end_s` of `sys` started from `init` (what an analysis that
/// needs the whole modal state, e.g. `analysis::lyapunov::max_lyapunov_modal`, restarts from).
pub type ModalRun<'a> = dyn Fn(
        &crate::structure::ModalSystem,
        &crate::structure::ModalState,
        f64,
    ) -> Result<crate::structure::ModalState, SimError>
    + Send
    + Sync
    + 'a;

/// The modal run of the solver `name` with the run settings: `rk4` is
/// [`modal_rk4::ModalRk4`] at `dt`, `exact` is [`exact::modal::ModalExact`]; `None` for an
/// unknown name.
pub fn modal_run_by_name(name: &str, settings: &RunSettings) -> Option<Box<ModalRun<'static>>> {
    match name {
        "rk4" => {
            let dt_s = settings.dt_s;
            Some(Box::new(move |sys, init, t_end_s| {
                Ok(modal_rk4::ModalRk4 { dt_s }
                    .run(sys, init, t_end_s, &mut ())?
                    .final_state)
            }))
        }
        "exact" => Some(Box::new(|sys, init, t_end_s| {
            Ok(exact::modal::ModalExact::default()
                .run(sys, init, t_end_s, &mut ())?
                .final_state)
        })),
        _ => None,
    }
}

/// Names of the solvers the library provides.
pub const SOLVER_NAMES: [&str; 2] = ["rk4", "exact"];

/// Build a solver by name with the run settings (`dt` is used by fixed-step solvers).
pub fn solver_by_name(name: &str, settings: &RunSettings) -> Option<Box<dyn Solver>> {
    match name {
        "rk4" => Some(Box::new(Rk4 {
            dt_s: settings.dt_s,
        })),
        "exact" => Some(Box::new(Exact::default())),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// B7: solvers (and boxed ones) can be sent to and shared between threads.
    #[test]
    fn solvers_are_send_and_sync() {
        fn send_sync<T: Send + Sync + ?Sized>() {}
        send_sync::<Exact>();
        send_sync::<Rk4>();
        send_sync::<dyn Solver>();
        send_sync::<Box<dyn Solver>>();
    }
}
