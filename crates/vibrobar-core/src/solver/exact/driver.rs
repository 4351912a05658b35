//! The one event loop of the exact solver: the ball's modes and every transition between them,
//! written once over a bar kernel.
//!
//! A run is a sequence of closed-form segments, each in one mode of the ball ([`Md`]): free
//! flight with a friction sign, stuck to the bar, pressed on a wall, or (under the `hertz` law)
//! in a compliant contact phase. What decides the next mode at an event depends only on the
//! cavity and its laws, read at the cavity through the contact row: the relative motion `w`,
//! `ẇ`, the bar's acceleration there without the ball's force (`a_b`), the pair's acceleration
//! when the ball is held, the inverse effective mass `κ = 1/m_d + 1/M_eff`. This module holds
//! those decisions once, for every bar:
//!
//! * [`Cavity`]: what the decisions read (the laws' constants and the kinematics at the cavity
//!   of one state), implemented by each bar's run constants;
//! * [`Kernel`]: what the loop asks a bar to do (build and search a segment in a mode and close
//!   it, apply the impact law, hold the ball over a summed chatter sequence, run a compliant
//!   contact phase, record an event), implemented by each bar's run (the lumped bar in
//!   [`super`], the N-mode bar in [`super::modal`]);
//! * the transitions: [`run`] and [`advance`] (the loop), the start ([`initial_mode`],
//!   [`at_zero_velocity`]), `ẇ = 0` (stick or switch), the impact with the chatter test and its
//!   summed limit, the wall-contact test ([`contact_test`], [`wall_touch`]), unstick and release;
//! * [`Tail`]: the last events before the event limit and the likely cause named in the error.
//!
//! The arithmetic of a segment (its closed form, the event functions, the root search, the
//! integrals) is the kernel's; the decisions here are the same expressions on the same values
//! for every kernel, so a kernel's runs are bit for bit what its own copy of this logic gave.
//!
//! The transitions, each derived from the forces (the laws are [`crate::damper`]'s):
//! * impact at `w = ±l_g` moving into the wall: the kernel's impact law, then, if the ball is
//!   left at rest on the wall, the contact test; else the chatter test: the relative
//!   accelerations of the flights away (`a_away`, friction sign `−s`) and back (`a_back`) both
//!   push the ball to the same wall and the bounces shrink by `q = e√(a_back/a_away) < 1`, so
//!   the sequence sums to `Δt = (|ẇ+|/a_away)(1 + √(a_away/a_back))/(1 − q)`; below resolution
//!   (apex under the kernel's height, or `Δt` under its time) the kernel holds the ball at the
//!   plastic limit for `Δt` and the [`EventKind::ChatterLimit`] carries the loss;
//! * `ẇ = 0` in free flight: `coulomb` sticks if `|a_b| ≤ Fκ`, else (and always as published)
//!   the sliding sign reverses;
//! * unstick when the holding force reaches `±F`, release when the force pressing the ball on
//!   its wall reaches the holding capacity;
//! * a start at `ẇ = 0` with `sgn(0) = 0` (as published) departs the way `ẅ` points with
//!   `F_rf = 0`, i.e. against `a_b`, looking at its derivatives when it vanishes.

use super::CONFINEMENT_TOL_M;
use crate::damper::friction::{can_stick, holding_capacity_n, sgn0, sliding_friction_on_ball_n};
use crate::error::{EventLimitCause, SimError};
use crate::params::FrictionModel;
use crate::solver::{EventKind, RunSummary, Wall};

/// `which` of a search that reached its work bound: the segment ends at the proven point
/// without an event and the same mode goes on from there.
pub(super) const HORIZON: u8 = u8::MAX;

/// `which` of the chip thickness reaching 0 in a cutting run: the tool leaves or re-enters the
/// cut; the segment ends there and the same mode goes on with the other force.
pub(super) const CUT: u8 = u8::MAX - 1;

/// The ball's mode, with the departure orders of the free-flight event functions at the
/// segment start.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Md {
    /// Free flight with friction sign `σ` (0: no friction force); orders for wall +, wall −,
    /// `σẇ`.
    Free {
        sigma: f64,
        k_plus: usize,
        k_minus: usize,
        k_sw: usize,
    },
    /// Stuck to the bar away from the walls (`coulomb`).
    Stick,
    /// Pressed on a wall.
    Contact(Wall),
    /// `hertz` law: the ball touches the wall (`ẇ` into it or 0); a compliant contact phase
    /// follows.
    HertzTouch(Wall),
}

/// The wall on side `s` (`+` for `s > 0`).
pub(super) fn wall_of(s: f64) -> Wall {
    if s > 0.0 {
        Wall::Plus
    } else {
        Wall::Minus
    }
}

/// Free flight with friction sign `σ` whose event functions all start with order 0 (no zero
/// at hand).
pub(super) fn flight(sigma: f64) -> Md {
    Md::Free {
        sigma,
        k_plus: 0,
        k_minus: 0,
        k_sw: 0,
    }
}

/// Free flight leaving `ẇ = 0` in direction `σ` (the switch function departs with order 1),
/// optionally from a wall it was pressed on (that wall function departs with order 2).
pub(super) fn free_departing(sigma: f64, wall: Option<Wall>) -> Md {
    Md::Free {
        sigma,
        k_plus: if wall == Some(Wall::Plus) { 2 } else { 0 },
        k_minus: if wall == Some(Wall::Minus) { 2 } else { 0 },
        k_sw: 1,
    }
}

/// Free flight leaving wall `sw` with `ẇ ≠ 0`.
pub(super) fn after_wall_free(sw: f64, dw: f64) -> Md {
    Md::Free {
        sigma: sgn0(dw),
        k_plus: if sw > 0.0 { 1 } else { 0 },
        k_minus: if sw < 0.0 { 1 } else { 0 },
        k_sw: 0,
    }
}

/// What the transitions read of a bar's state: time and the relative motion at the cavity.
pub(super) trait BallState {
    /// Time.
    fn t(&self) -> f64;
    /// `w = v − u(x_d)`.
    fn w(&self) -> f64;
    /// `ẇ`.
    fn dw(&self) -> f64;
    /// Set `w` (to a wall, exactly).
    fn set_w(&mut self, w: f64);
    /// Set `ẇ`.
    fn set_dw(&mut self, dw: f64);
    /// Every coordinate is finite.
    fn is_finite(&self) -> bool;
}

/// [`BallState`] for a state type with the fields `t`, `w`, `dw`, finite where `$finite` (an
/// expression in `$s`, the state) holds.
macro_rules! ball_state {
    ($st:ty, |$s:ident| $finite:expr) => {
        impl $crate::solver::exact::driver::BallState for $st {
            fn t(&self) -> f64 {
                self.t
            }
            fn w(&self) -> f64 {
                self.w
            }
            fn dw(&self) -> f64 {
                self.dw
            }
            fn set_w(&mut self, w: f64) {
                self.w = w;
            }
            fn set_dw(&mut self, dw: f64) {
                self.dw = dw;
            }
            fn is_finite(&self) -> bool {
                let $s = self;
                $finite
            }
        }
    };
}
pub(super) use ball_state;

/// The [`Cavity`] constants of a run's constants that keep them in the fields `lg`, `e`, `md`,
/// `fl`, `model`, `chatter_h`, `chatter_t`, `hertz` (inside `impl Cavity for …`), of `self`
/// or of the field path given (`cavity_constants!(run.cs)`).
macro_rules! cavity_constants {
    ($($p:ident).*) => {
        fn half_gap_m(&self) -> f64 {
            self$(.$p)*.lg
        }
        fn restitution(&self) -> f64 {
            self$(.$p)*.e
        }
        fn ball_mass_kg(&self) -> f64 {
            self$(.$p)*.md
        }
        fn friction_level_n(&self) -> f64 {
            self$(.$p)*.fl
        }
        fn friction_model(&self) -> $crate::params::FrictionModel {
            self$(.$p)*.model
        }
        fn chatter_resolution(&self) -> (f64, f64) {
            (self$(.$p)*.chatter_h, self$(.$p)*.chatter_t)
        }
        fn compliant(&self) -> bool {
            self$(.$p)*.hertz.is_some()
        }
    };
}
pub(super) use cavity_constants;

/// What the transitions read of a bar and its cavity: the laws' constants and the kinematics at
/// the cavity of one state.
pub(super) trait Cavity {
    /// The bar's state.
    type St: BallState;
    /// `l_g`.
    fn half_gap_m(&self) -> f64;
    /// `e`.
    fn restitution(&self) -> f64;
    /// `m_d`.
    fn ball_mass_kg(&self) -> f64;
    /// Friction level `F` (0 when frictionless).
    fn friction_level_n(&self) -> f64;
    /// The friction law.
    fn friction_model(&self) -> FrictionModel;
    /// `κ = 1/m_d + 1/M_eff`, the inverse effective mass of the contact row.
    fn kappa(&self) -> f64;
    /// The chatter resolution: a sequence whose first apex is below the height or whose sum is
    /// shorter than the time is summed to its limit.
    fn chatter_resolution(&self) -> (f64, f64);
    /// A wall touch starts a compliant (`hertz`) contact phase instead of the impact law.
    fn compliant(&self) -> bool;
    /// `a_b`: the bar's acceleration at the cavity without the ball's force.
    fn a_b(&self, s: &Self::St) -> f64;
    /// The acceleration at the cavity of the bar with the ball held there (the pair).
    fn held_acceleration(&self, s: &Self::St) -> f64;
    /// The first and second time derivatives of `a_b` (given `a_b` itself), for a start at
    /// `ẇ = 0` under the as-published law.
    fn a_b_rates(&self, s: &Self::St, a_b: f64) -> (f64, f64);
    /// `g_s`: the ball's acceleration from a constant body force along the gap
    /// (`damper.gravity_along_gap_m_s2`), 0 without one. The kernels that support it fold it
    /// into their closed forms (free flight: the ball's acceleration gains `g_s`; held: the
    /// pair's load gains `m_d g_s`, in [`Cavity::held_acceleration`]); the others refuse it at
    /// the start of a run and keep this default.
    fn ball_gravity(&self) -> f64 {
        0.0
    }
    /// `a_b − g_s`, what the ball's relative motion reads of the bar: in free flight
    /// `ẅ = F_ball κ − (a_b − g_s)`, so every test on `a_b` (stick, the sliding direction from
    /// rest, the chatter test) reads this. `a_b` itself, to the bit, without a body force.
    fn a_rel(&self, s: &Self::St) -> f64 {
        let ab = self.a_b(s);
        let g = self.ball_gravity();
        if g == 0.0 {
            ab
        } else {
            ab - g
        }
    }

    /// Friction is on and has a level.
    fn frictional(&self) -> bool {
        self.friction_model() != FrictionModel::None && self.friction_level_n() > 0.0
    }
    /// Friction force on the ball while sliding with sign `σ`.
    fn fb(&self, sigma: f64) -> f64 {
        sliding_friction_on_ball_n(self.friction_model(), self.friction_level_n(), sigma)
    }
    /// Largest `s·m_d ü_pair` for which the ball stays on wall `s`.
    fn f_hold(&self) -> f64 {
        holding_capacity_n(self.friction_model(), self.friction_level_n())
    }
    /// What names the cause at the event limit, with the forcing's `Ω` and the bar's first
    /// damped frequency `ω_d,1`.
    fn limit_facts(&self, omega_rad_s: f64, wd1_rad_s: f64) -> LimitFacts {
        LimitFacts {
            restitution: self.restitution(),
            frictional: self.frictional(),
            model: self.friction_model(),
            omega_rad_s,
            fast_dw_m_s: 10.0 * self.half_gap_m() * omega_rad_s.max(wd1_rad_s),
        }
    }
}

/// What the one loop asks of a bar during a run (its constants, its books, its buffers).
pub(super) trait Kernel {
    /// The run's constants, read by the transitions.
    type Cs: Cavity;
    /// The constants.
    fn cs(&self) -> &Self::Cs;
    /// One free-flight segment from `s` with friction sign `σ` and departure orders `[wall +,
    /// wall −, ẇ = 0]`, at most to `t_end_s`: built, searched, handed to the observers and
    /// checked; `s` becomes its end state. Returns which event ended it: 0 none (`t_end_s`
    /// reached), 1 wall +, 2 wall −, 3 `ẇ = 0`, [`HORIZON`], [`CUT`].
    fn free_flight(
        &mut self,
        sigma: f64,
        orders: [usize; 3],
        s: &mut <Self::Cs as Cavity>::St,
        t_end_s: f64,
    ) -> Result<u8, SimError>;
    /// One segment with the ball held (`Md::Stick` or `Md::Contact`) from `s`, as
    /// [`Kernel::free_flight`]; `s` becomes its end state with `ẇ = 0`. Returns 0 none, 1 the
    /// ball lags (unstick), 2 it leads (unstick), 3 release, [`HORIZON`], [`CUT`].
    fn held(
        &mut self,
        mode: Md,
        s: &mut <Self::Cs as Cavity>::St,
        t_end_s: f64,
    ) -> Result<u8, SimError>;
    /// The impact law at wall `sw` (`ẇ` into it; a graze hits with `ẇ− = 0`): `w` set to
    /// exactly `sw·l_g`, `s` becomes the state after it, the [`EventKind::Impact`] is recorded.
    fn impact_law(&mut self, sw: f64, s: &mut <Self::Cs as Cavity>::St) -> Result<(), SimError>;
    /// A chatter sequence at wall `sw` summed over `dt`: the plastic limit now, the ball held on
    /// the wall for `dt`; `s` becomes the state at the accumulation point (`w = sw·l_g`,
    /// `ẇ = 0`). Returns the kinetic energy the sequence removed.
    fn chatter_hold(
        &mut self,
        sw: f64,
        dt: f64,
        s: &mut <Self::Cs as Cavity>::St,
    ) -> Result<f64, SimError>;
    /// Record an event (counters, the event limit, the invariant checks, the observers).
    fn event(
        &mut self,
        kind: EventKind,
        before: &<Self::Cs as Cavity>::St,
        after: &<Self::Cs as Cavity>::St,
    ) -> Result<(), SimError>;
    /// The compliant contact phase at `wall` from the touch `s`, at most to `t_end_s`; the next
    /// mode, or `None` at the end of the run.
    fn compliant_contact(
        &mut self,
        wall: Wall,
        s: &mut <Self::Cs as Cavity>::St,
        t_end_s: f64,
    ) -> Result<Option<Md>, SimError>;
    /// A segment ended where the tool left or re-entered the cut ([`CUT`]).
    fn cut_event(&mut self) {}
}

/// Run from `s` to `t_end_s`: the mode at the start, then segment after segment.
pub(super) fn run<K: Kernel>(
    k: &mut K,
    s: &mut <K::Cs as Cavity>::St,
    t_end_s: f64,
) -> Result<(), SimError> {
    let mut mode = initial_mode(k, s)?;
    while s.t() < t_end_s {
        match advance(k, mode, s, t_end_s)? {
            Some(m) => mode = m,
            None => break,
        }
    }
    Ok(())
}

/// One segment of mode `mode` from `s`, at most to `t_end_s`; the next mode, or `None` when
/// `t_end_s` was reached.
pub(super) fn advance<K: Kernel>(
    k: &mut K,
    mode: Md,
    s: &mut <K::Cs as Cavity>::St,
    t_end_s: f64,
) -> Result<Option<Md>, SimError> {
    match mode {
        Md::Free {
            sigma,
            k_plus,
            k_minus,
            k_sw,
        } => free(k, sigma, [k_plus, k_minus, k_sw], s, t_end_s),
        Md::Stick | Md::Contact(_) => held(k, mode, s, t_end_s),
        Md::HertzTouch(wall) => k.compliant_contact(wall, s, t_end_s),
    }
}

/// A free-flight segment and the transition at its end.
fn free<K: Kernel>(
    k: &mut K,
    sigma: f64,
    orders: [usize; 3],
    s: &mut <K::Cs as Cavity>::St,
    t_end_s: f64,
) -> Result<Option<Md>, SimError> {
    match k.free_flight(sigma, orders, s, t_end_s)? {
        0 => Ok(None),
        // The tool left or re-entered the cut: the same flight goes on with the other force.
        CUT => {
            k.cut_event();
            Ok(Some(flight(sigma)))
        }
        // The same flight on from the proven point, no zero at hand any more.
        HORIZON => Ok(Some(flight(sigma))),
        which @ (1 | 2) => {
            let sw = if which == 1 { 1.0 } else { -1.0 };
            if k.cs().compliant() {
                s.set_w(sw * k.cs().half_gap_m());
                // A graze (touch with ẇ ≈ 0 or already leaving by round-off) touches with
                // ẇ = 0; the contact phase reads only the approach max(sw·ẇ, 0).
                if sw * s.dw() <= 0.0 {
                    s.set_dw(0.0);
                }
                Ok(Some(Md::HertzTouch(wall_of(sw))))
            } else {
                impact(k, sw, s).map(Some)
            }
        }
        _ => {
            s.set_dw(0.0);
            friction_zero(k, sigma, s).map(Some)
        }
    }
}

/// A segment with the ball held (stick or wall contact) and the unstick or release at its end.
fn held<K: Kernel>(
    k: &mut K,
    mode: Md,
    s: &mut <K::Cs as Cavity>::St,
    t_end_s: f64,
) -> Result<Option<Md>, SimError> {
    let which = k.held(mode, s, t_end_s)?;
    match which {
        0 => return Ok(None),
        HORIZON => return Ok(Some(mode)),
        CUT => {
            k.cut_event();
            return Ok(Some(mode));
        }
        _ => {}
    }
    let (kind, new_mode) = match (which, mode) {
        (1, _) => (EventKind::Unstick, free_departing(-1.0, None)),
        (2, _) => (EventKind::Unstick, free_departing(1.0, None)),
        (_, Md::Contact(wl)) => (
            EventKind::ContactRelease { wall: wl },
            free_departing(-wl.sign(), Some(wl)),
        ),
        _ => unreachable!("only contact has a release margin"),
    };
    k.event(kind, s, s)?;
    Ok(Some(new_mode))
}

/// Mode at the start of a run (or after the state was set from outside).
pub(super) fn initial_mode<K: Kernel>(
    k: &mut K,
    s: &mut <K::Cs as Cavity>::St,
) -> Result<Md, SimError> {
    let lg = k.cs().half_gap_m();
    for sw in [1.0, -1.0] {
        if sw * s.w() >= lg {
            s.set_w(sw * lg);
            if sw * s.dw() > 0.0 {
                if k.cs().compliant() {
                    return Ok(Md::HertzTouch(wall_of(sw)));
                }
                return impact(k, sw, s);
            }
            if s.dw() == 0.0 {
                return Ok(wall_touch(k.cs(), sw, s));
            }
            return Ok(after_wall_free(sw, s.dw()));
        }
    }
    if s.dw() != 0.0 {
        return Ok(flight(sgn0(s.dw())));
    }
    Ok(at_zero_velocity(k.cs(), s))
}

/// `ẇ = 0` away from the walls, no event history: which way does the ball go?
pub(super) fn at_zero_velocity<C: Cavity>(cs: &C, s: &C::St) -> Md {
    if !cs.frictional() {
        return flight(0.0);
    }
    let ab = cs.a_rel(s);
    if can_stick(cs.friction_model()) {
        if ab.abs() <= cs.friction_level_n() * cs.kappa() {
            return Md::Stick;
        }
        return free_departing(-sgn0(ab), None);
    }
    // as-published, sgn(0) = 0: the ball departs the way ẅ points with F_rf = 0, i.e. −a_b,
    // looking at the higher derivatives of a_b when it vanishes (start from rest).
    let mut sigma = -sgn0(ab);
    if sigma == 0.0 {
        // The body force is constant: `a_b − g_s` has the rates of `a_b`.
        let (dab, ddab) = cs.a_b_rates(s, cs.a_b(s));
        sigma = -sgn0(dab);
        if sigma == 0.0 {
            sigma = -sgn0(ddab);
        }
    }
    if sigma == 0.0 {
        return flight(0.0);
    }
    free_departing(sigma, None)
}

/// `ẇ` reached 0 in free flight with friction sign `σ`.
fn friction_zero<K: Kernel>(
    k: &mut K,
    sigma: f64,
    s: &<K::Cs as Cavity>::St,
) -> Result<Md, SimError> {
    let cs = k.cs();
    let sticks =
        can_stick(cs.friction_model()) && cs.a_rel(s).abs() <= cs.friction_level_n() * cs.kappa();
    if sticks {
        k.event(EventKind::Stick, s, s)?;
        return Ok(Md::Stick);
    }
    k.event(EventKind::FrictionSwitch, s, s)?;
    // as-published: the crossing is transversal, the sign simply reverses. coulomb: not
    // sticking means |a_b| > Fκ, and the ball slides on against a_b, i.e. reversed too.
    Ok(free_departing(-sigma, None))
}

/// Ball at wall `sw` with `ẇ` pointing into it: the impact law, then the contact or chatter
/// test.
fn impact<K: Kernel>(k: &mut K, sw: f64, s: &mut <K::Cs as Cavity>::St) -> Result<Md, SimError> {
    k.impact_law(sw, s)?;
    if s.dw() == 0.0 {
        return Ok(contact_test(k.cs(), sw, s));
    }
    if let Some(dt) = chatter_time(k.cs(), sw, s) {
        return chatter_limit(k, sw, dt, s);
    }
    Ok(after_wall_free(sw, s.dw()))
}

/// The chatter test after an impact at wall `sw`: `Some(Δt)`, the duration of the remaining
/// sequence, when it accumulates (`q < 1`) below the resolution. Also at `e = 1`: coulomb
/// friction alone (`a_back < a_away`) makes the bounces shrink to a finite-time accumulation;
/// `e = 1` without friction gives `q = 1`, no accumulation.
fn chatter_time<C: Cavity>(cs: &C, sw: f64, s: &C::St) -> Option<f64> {
    let dw = s.dw();
    let sigma = sgn0(dw);
    let a_b = cs.a_rel(s);
    let ddw_away = cs.fb(sigma) * cs.kappa() - a_b;
    let ddw_back = cs.fb(-sigma) * cs.kappa() - a_b;
    if sw * ddw_away > 0.0 && sw * ddw_back > 0.0 {
        let (a1, a2) = (ddw_away.abs(), ddw_back.abs());
        let q = cs.restitution() * (a2 / a1).sqrt();
        let apex = 0.5 * dw * dw / a1;
        if q < 1.0 {
            let dt = dw.abs() / a1 * (1.0 + (a1 / a2).sqrt()) / (1.0 - q);
            let (height, time) = cs.chatter_resolution();
            if apex < height || dt < time {
                return Some(dt);
            }
        }
    }
    None
}

/// Sum the chatter sequence: the kernel holds the ball at the plastic limit for `Δt`, the
/// [`EventKind::ChatterLimit`] carries the loss, then the contact test at the accumulation
/// point.
fn chatter_limit<K: Kernel>(
    k: &mut K,
    sw: f64,
    dt: f64,
    s: &mut <K::Cs as Cavity>::St,
) -> Result<Md, SimError> {
    let loss = k.chatter_hold(sw, dt, s)?;
    k.event(
        EventKind::ChatterLimit {
            wall: wall_of(sw),
            energy_loss_j: loss,
        },
        s,
        s,
    )?;
    Ok(contact_test(k.cs(), sw, s))
}

/// Ball at wall `sw` with `ẇ = 0`: does it stay pressed on it (`sw·m_d ü_pair ≤ f_hold`)?
/// With a body force on the ball, the wall has to supply `m_d (ü_pair − g_s)` of it:
/// `sw·m_d (ü_pair − g_s) ≤ f_hold`.
pub(super) fn contact_test<C: Cavity>(cs: &C, sw: f64, s: &C::St) -> Md {
    let g = cs.ball_gravity();
    let ddu_pair = if g == 0.0 {
        cs.held_acceleration(s)
    } else {
        cs.held_acceleration(s) - g
    };
    if sw * cs.ball_mass_kg() * ddu_pair <= cs.f_hold() {
        Md::Contact(wall_of(sw))
    } else {
        free_departing(-sw, Some(wall_of(sw)))
    }
}

/// Ball at wall `sw` with `ẇ = 0`: [`contact_test`], where a pressed ball under the `hertz` law
/// starts a (resting) compliant contact instead of riding the wall rigidly.
pub(super) fn wall_touch<C: Cavity>(cs: &C, sw: f64, s: &C::St) -> Md {
    match contact_test(cs, sw, s) {
        Md::Contact(w) if cs.compliant() => Md::HertzTouch(w),
        m => m,
    }
}

/// How many events before the limit [`Tail`] looks at.
pub(super) const TAIL_EVENTS: u64 = 1024;

/// What names the cause at the event limit, besides the events themselves.
#[derive(Debug, Clone, Copy)]
pub(super) struct LimitFacts {
    /// `e`.
    pub restitution: f64,
    /// Friction is on and has a level.
    pub frictional: bool,
    /// The friction law.
    pub model: FrictionModel,
    /// `Ω`.
    pub omega_rad_s: f64,
    /// A relative speed beyond what the bar's motion over the gap gives:
    /// `10 l_g max(Ω, ω_d,1)`.
    pub fast_dw_m_s: f64,
}

/// The last events before the event limit, by kind, to name the likely cause.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Tail {
    /// Recording starts after this many events.
    pub from: u64,
    t_first: f64,
    n: u64,
    impacts: u64,
    /// Impacts with `ẇ− = 0` (touches), contact releases and chatter limits: a ball on a wall.
    on_wall: u64,
    switches: u64,
    stick_slip: u64,
    largest_dw: f64,
}

impl Tail {
    /// Recording from [`TAIL_EVENTS`] before `max_events` on.
    pub fn new(max_events: u64) -> Tail {
        Tail {
            from: max_events.saturating_sub(TAIL_EVENTS),
            ..Default::default()
        }
    }

    /// One more event.
    pub fn record(&mut self, t: f64, kind: &EventKind) {
        if self.n == 0 {
            self.t_first = t;
        }
        self.n += 1;
        match *kind {
            EventKind::Impact { dw_m_s, .. } => {
                self.impacts += 1;
                if dw_m_s == 0.0 {
                    self.on_wall += 1;
                }
                self.largest_dw = self.largest_dw.max(dw_m_s.abs());
            }
            EventKind::ContactRelease { .. } | EventKind::ChatterLimit { .. } => self.on_wall += 1,
            EventKind::FrictionSwitch => self.switches += 1,
            EventKind::Stick | EventKind::Unstick => self.stick_slip += 1,
        }
    }

    /// The error at the limit: the event rate and the likely cause.
    pub fn error(&self, facts: &LimitFacts, limit: u64, t: f64) -> SimError {
        let half = self.n / 2;
        let elastic = facts.restitution >= 1.0 && !facts.frictional;
        let fast = self.largest_dw > facts.fast_dw_m_s;
        let cause = if self.n == 0 {
            EventLimitCause::Dense
        } else if self.on_wall > half {
            EventLimitCause::RestingOnWall
        } else if self.stick_slip > half {
            EventLimitCause::StickSlip
        } else if elastic && self.impacts > half {
            EventLimitCause::ElasticMicroBouncing {
                largest_dw_m_s: self.largest_dw,
            }
        } else if facts.model == FrictionModel::AsPublished
            && facts.frictional
            && self.impacts + self.switches > half
            && fast
        {
            EventLimitCause::FrictionRunaway {
                largest_dw_m_s: self.largest_dw,
            }
        } else {
            EventLimitCause::Dense
        };
        let periods = (t - self.t_first) * facts.omega_rad_s / (2.0 * std::f64::consts::PI);
        SimError::TooManyEvents {
            limit,
            t_s: t,
            events_per_period: self.n as f64 / periods,
            cause,
        }
    }
}

/// The books every kernel keeps alike: the run's summary, the event limit and the tail of events
/// before it, the invariant checks.
#[derive(Debug, Clone, Copy)]
pub(super) struct Tally {
    /// Counters, the largest penetration, the final state.
    pub summary: RunSummary,
    /// The event limit.
    pub max_events: u64,
    /// Check finiteness and confinement at every event and segment end.
    pub check: bool,
    /// `l_g`.
    pub lg: f64,
    /// What the last events before the event limit did (recorded only near the limit).
    pub tail: Tail,
}

impl Tally {
    /// Books of a run starting with `summary`.
    pub fn new(summary: RunSummary, max_events: u64, check: bool, lg: f64) -> Tally {
        Tally {
            summary,
            max_events,
            check,
            lg,
            tail: Tail::new(max_events),
        }
    }

    /// The penetration of `s` recorded; with the checks on, `s` finite and confined to
    /// [`CONFINEMENT_TOL_M`].
    #[inline]
    pub fn check_state<S: BallState>(&mut self, s: &S) -> Result<(), SimError> {
        let pen = s.w().abs() - self.lg;
        if pen > self.summary.max_penetration_m {
            self.summary.max_penetration_m = pen;
        }
        if self.check {
            if !s.is_finite() {
                return Err(SimError::NonFinite { t_s: s.t() });
            }
            if pen > CONFINEMENT_TOL_M {
                return Err(SimError::Confinement {
                    t_s: s.t(),
                    w_m: s.w(),
                    half_gap_m: self.lg,
                });
            }
        }
        Ok(())
    }

    /// One more event of `kind` at `t`: counted, and near the limit recorded (the limit's error
    /// names its likely cause from `facts`).
    #[inline]
    pub fn count(
        &mut self,
        t: f64,
        kind: &EventKind,
        facts: impl FnOnce() -> LimitFacts,
    ) -> Result<(), SimError> {
        self.summary.events += 1;
        if let EventKind::Impact { .. } = kind {
            self.summary.impacts += 1;
        }
        if self.summary.events > self.tail.from {
            self.near_limit(t, kind, facts())?;
        }
        Ok(())
    }

    /// The last events before the limit: recorded, and the error at the limit (kept out of
    /// line, it runs for the last [`TAIL_EVENTS`] events of a run at most).
    #[cold]
    #[inline(never)]
    fn near_limit(&mut self, t: f64, kind: &EventKind, facts: LimitFacts) -> Result<(), SimError> {
        if self.summary.events > self.max_events {
            return Err(self.tail.error(&facts, self.max_events, t));
        }
        self.tail.record(t, kind);
        Ok(())
    }
}
