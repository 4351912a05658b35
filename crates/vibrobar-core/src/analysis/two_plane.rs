//! Design points of the bar that bends in two planes: seeded ensembles of starts, their spread,
//! and the one-plane model beside them.
//!
//! Where the ball starts decides which of several coexisting motions a run settles on, in one
//! plane as in two, so a design point is an ensemble: member 0 is the ball at rest on the wall
//! gravity presses it onto, centred along the hole; every other member puts it at a uniformly
//! drawn place along the hole with uniformly drawn small velocities along it and across it
//! (away from the wall it rests on) ([`TwoPlaneEnsemble`]), from a seeded generator, so an
//! ensemble is reproducible. Both directions matter: on frictionless walls the motions along
//! and across the hole are independent, so starts that differ along the hole only would all
//! give the same motion across it.
//!
//! The one-plane counterpart ([`one_plane_system`]) is today's model of the same bar: the ball
//! in a slot along the hole with the axial gap, the whole force along it, the rolling friction
//! as a Coulomb force `(η/r)·m_d·g`, gravity's component along the hole as a body force on the
//! ball. Its members start from the same places and velocities along the hole.

use super::batch::{BatchError, Runner};
use super::case::run_case;
use super::ensemble::SplitMix64;
use crate::error::{ParamError, SimError};
use crate::params::two_plane::{TwoPlaneBar, TwoPlaneSystem};
use crate::params::{
    Bar, BarModel, Contact, Damper, Forcing, FrictionModel, RunSettings, State, System,
};
use crate::solver::two_plane_exact::{decoupled, TwoPlaneExact};
use crate::solver::two_plane_rk4::{
    Sampling, TwoPlaneEvent, TwoPlaneRk4, TwoPlaneSample, TwoPlaneStart, TwoPlaneSummary,
};
use crate::solver::{Exact, Observer};

/// How the members of a design point start.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TwoPlaneEnsemble {
    /// Members (member 0 is the centred start).
    pub members: usize,
    /// Seed of the generator.
    pub seed: u64,
    /// Largest speed given to a member: along the hole in `[−v, v]`, across it in `[0, v]` away
    /// from the wall it rests on (`[−v, v]` where it rests on none).
    pub start_speed_m_s: f64,
}

impl Default for TwoPlaneEnsemble {
    /// Eight members, seed 1, up to 0.01 m/s.
    fn default() -> Self {
        TwoPlaneEnsemble {
            members: 8,
            seed: 1,
            start_speed_m_s: 0.01,
        }
    }
}

impl TwoPlaneEnsemble {
    /// Check the fields.
    pub fn validate(&self) -> Result<(), ParamError> {
        crate::limits::check_count(
            "members (--members)",
            self.members,
            1,
            crate::limits::MAX_ENSEMBLE_MEMBERS,
            "",
        )?;
        crate::params::non_negative("start_speed_m_s", self.start_speed_m_s)?;
        crate::limits::check(
            "start_speed_m_s",
            self.start_speed_m_s,
            0.0,
            10.0,
            "a small disturbance, in m/s",
        )?;
        Ok(())
    }
}

/// The members' starts: the bar at rest, the ball on the wall gravity presses it onto.
pub fn starts(
    sys: &TwoPlaneSystem,
    ens: &TwoPlaneEnsemble,
) -> Result<Vec<TwoPlaneStart>, ParamError> {
    ens.validate()?;
    let l_g = sys.hole.half_axial_gap_m();
    let mut rng = SplitMix64::new(ens.seed);
    Ok((0..ens.members)
        .map(|i| {
            if i == 0 {
                TwoPlaneStart::resting(sys, 0.0)
            } else {
                let along = rng.uniform(-l_g, l_g);
                let v = ens.start_speed_m_s;
                let speed = rng.uniform(-v, v);
                let mut s = TwoPlaneStart::resting(sys, along);
                s.dw_hole_m_s[0] = speed;
                // Away from the wall across the hole it rests on.
                let w_n = s.w_hole_m[1];
                s.dw_hole_m_s[1] = if w_n == 0.0 {
                    rng.uniform(-v, v)
                } else {
                    -w_n.signum() * rng.uniform(0.0, v)
                };
                s
            }
        })
        .collect())
}

/// Which solver runs a two-plane system; `dt_s` is the reference solver's step wherever it runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TwoPlaneMethod {
    /// The exact solver where the planes decouple ([`decoupled`]), the reference elsewhere.
    Auto {
        /// The reference solver's step.
        dt_s: f64,
    },
    /// The exact solver; a system whose planes do not decouple is refused.
    Exact,
    /// The reference solver (RK4 at the given step with located events).
    Reference {
        /// Its step.
        dt_s: f64,
    },
}

impl Default for TwoPlaneMethod {
    /// `Auto` with the reference solver's default step.
    fn default() -> Self {
        TwoPlaneMethod::Auto {
            dt_s: TwoPlaneRk4::default().dt_s,
        }
    }
}

impl TwoPlaneMethod {
    /// The solver that runs `sys`: `"exact"` or `"reference"`.
    pub fn solver_for(&self, sys: &TwoPlaneSystem) -> &'static str {
        match self {
            TwoPlaneMethod::Auto { .. } if decoupled(sys).is_ok() => "exact",
            TwoPlaneMethod::Exact => "exact",
            _ => "reference",
        }
    }

    /// Run `sys` from `start` on the solver of [`TwoPlaneMethod::solver_for`].
    pub fn run(
        &self,
        sys: &TwoPlaneSystem,
        start: &TwoPlaneStart,
        settings: &RunSettings,
        on_event: &mut dyn FnMut(&TwoPlaneEvent),
    ) -> Result<TwoPlaneSummary, SimError> {
        self.run_from(sys, start, 0.0, settings, on_event, None)
    }

    /// [`TwoPlaneMethod::run`] from the state `start` at time `t0_s`, sampling the state as
    /// `sampling` asks.
    pub fn run_from<'a>(
        &self,
        sys: &TwoPlaneSystem,
        start: &TwoPlaneStart,
        t0_s: f64,
        settings: &RunSettings,
        on_event: &'a mut dyn FnMut(&TwoPlaneEvent),
        sampling: Option<Sampling<'a>>,
    ) -> Result<TwoPlaneSummary, SimError> {
        match self {
            TwoPlaneMethod::Auto { dt_s } | TwoPlaneMethod::Reference { dt_s }
                if self.solver_for(sys) == "reference" =>
            {
                TwoPlaneRk4 { dt_s: *dt_s }.run_from(sys, start, t0_s, settings, on_event, sampling)
            }
            _ => TwoPlaneExact::default().run_from(sys, start, t0_s, settings, on_event, sampling),
        }
    }
}

/// A design point's answer: every member's run of the two-plane model, the one-plane model from
/// the same starts, and the bar without its ball.
#[derive(Debug, Clone, PartialEq)]
pub struct DesignPoint {
    /// The members' starts.
    pub starts: Vec<TwoPlaneStart>,
    /// The members' runs.
    pub members: Vec<TwoPlaneSummary>,
    /// The one-plane model's RMS from each member's start ([`one_plane_system`], with the
    /// rolling friction as a Coulomb force when the walls have friction).
    pub one_plane_rms_m: Vec<f64>,
    /// RMS of the bar without its ball.
    pub solid_rms_m: f64,
    /// The solver that ran the members: `"exact"` or `"reference"`.
    pub solver: &'static str,
}

impl DesignPoint {
    /// Each member's reduction of the RMS along the force against the bar without its ball, %.
    pub fn reductions_pct(&self) -> Vec<f64> {
        self.members
            .iter()
            .map(|m| 100.0 * (1.0 - m.rms_along_force_m / self.solid_rms_m))
            .collect()
    }

    /// The one-plane model's reductions, %.
    pub fn one_plane_reductions_pct(&self) -> Vec<f64> {
        self.one_plane_rms_m
            .iter()
            .map(|r| 100.0 * (1.0 - r / self.solid_rms_m))
            .collect()
    }
}

/// Run the design points `systems`, every member of every point in parallel on `runner`.
pub fn design_points(
    systems: &[TwoPlaneSystem],
    ens: &TwoPlaneEnsemble,
    method: TwoPlaneMethod,
    settings: &RunSettings,
    runner: &Runner,
) -> Result<Vec<DesignPoint>, BatchError<SimError>> {
    let starts: Vec<Vec<TwoPlaneStart>> = systems
        .iter()
        .map(|s| starts(s, ens))
        .collect::<Result<_, _>>()
        .map_err(|e| BatchError::Point(e.into()))?;
    let jobs: Vec<(usize, TwoPlaneStart)> = starts
        .iter()
        .enumerate()
        .flat_map(|(i, st)| st.iter().map(move |s| (i, *s)))
        .collect();
    let two = runner.each(&jobs, |(i, st)| {
        method.run(&systems[*i], st, settings, &mut |_| {})
    })?;
    let one_plane: Vec<System> = systems
        .iter()
        .map(|s| {
            let friction = if s.ball.frictionless() {
                FrictionModel::None
            } else {
                FrictionModel::Coulomb
            };
            one_plane_system(s, friction)
        })
        .collect();
    let one = runner.each(&jobs, |(i, st)| {
        one_plane_rms_m(&one_plane[*i], &one_plane_start(st), settings)
    })?;
    let solid = runner.each(systems, |sys| solid_rms_m(sys, settings))?;
    let mut two = two.into_iter();
    let mut one = one.into_iter();
    Ok(systems
        .iter()
        .zip(starts)
        .zip(solid)
        .map(|((sys, st), solid_rms_m)| {
            let n = st.len();
            DesignPoint {
                members: two.by_ref().take(n).collect(),
                one_plane_rms_m: one.by_ref().take(n).collect(),
                starts: st,
                solid_rms_m,
                solver: method.solver_for(sys),
            }
        })
        .collect())
}

/// Mean, standard error and range of an ensemble's values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spread {
    /// Mean.
    pub mean: f64,
    /// Standard error of the mean, `s/√n` (0 for one member).
    pub std_err: f64,
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
    /// Members.
    pub n: usize,
}

impl Spread {
    /// Of `values` (at least one).
    pub fn of(values: &[f64]) -> Spread {
        let n = values.len();
        let mean = values.iter().sum::<f64>() / n as f64;
        let var = if n > 1 {
            values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1) as f64
        } else {
            0.0
        };
        Spread {
            mean,
            std_err: (var / n as f64).sqrt(),
            min: values.iter().copied().fold(f64::INFINITY, f64::min),
            max: values.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            n,
        }
    }
}

/// The one-plane model of the same bar and ball: the slot along the hole, the whole force along
/// it, the bar's first principal axis (the first family of measured modes), gravity's component along the hole on the ball, and
/// `friction` (`coulomb` with the rolling friction as the Coulomb force, or none; none without
/// gravity, which leaves the ball no normal load).
pub fn one_plane_system(sys: &TwoPlaneSystem, friction: FrictionModel) -> System {
    // Without gravity the one-plane friction has no normal load: none. (The one-plane model
    // needs a positive gravity for its friction level; it is not used then.)
    let weightless = sys.gravity.m_s2 <= 0.0;
    let friction = if weightless {
        FrictionModel::None
    } else {
        friction
    };
    System {
        bar: match &sys.bar {
            TwoPlaneBar::Lumped(b) => BarModel::Lumped(Bar {
                mass_kg: b.mass_kg,
                stiffness_n_per_m: b.stiffness_n_per_m[0],
                damping_ratio: b.damping_ratio[0],
            }),
            TwoPlaneBar::Round(m) => BarModel::Modal(*m),
            TwoPlaneBar::Measured(p) => BarModel::Modal(p.modes[0]),
        },
        damper: Some(Damper {
            ball_mass_kg: sys.ball.mass_kg,
            ball_radius_m: sys.ball.radius_m,
            restitution: sys.ball.restitution,
            gap_m: sys.hole.axial_gap_m,
            rolling_friction_m: sys.ball.rolling_friction_m,
            friction,
            friction_force_n: None,
            contact: Contact::default(),
            gravity_along_gap_m_s2: gravity_along_hole_m_s2(sys),
        }),
        forcing: Forcing {
            amplitude_n: sys.forcing.amplitude_n,
            frequency: sys.forcing.frequency,
            static_force_n: 0.0,
        },
        gravity_m_s2: if weightless {
            crate::params::STANDARD_GRAVITY_M_S2
        } else {
            sys.gravity.m_s2
        },
    }
}

/// Gravity's component along the hole (0 where the hole is level to within 1e-12 of g).
pub fn gravity_along_hole_m_s2(sys: &TwoPlaneSystem) -> f64 {
    let g = sys.gravity.m_s2;
    let along = g
        * (sys.gravity.angle_deg - sys.hole.angle_deg)
            .to_radians()
            .cos();
    if along.abs() <= 1e-12 * g {
        0.0
    } else {
        along
    }
}

/// The one-plane start of a two-plane member: the bar at rest, the ball where it is along the
/// hole with its velocity along it.
pub fn one_plane_start(start: &TwoPlaneStart) -> State {
    State {
        v_m: start.w_hole_m[0],
        dv_m_s: start.dw_hole_m_s[0],
        ..State::REST
    }
}

/// The largest Lyapunov exponent of the two-plane bar from `start`, by two-trajectory
/// divergence with renormalisation (the method of [`crate::analysis::lyapunov`]) on `method`'s
/// solver. The state is scaled as the one-plane one, per plane: the bar's `u_x, u_y` by
/// `s_u = F0/K`, their velocities by `ω₁ s_u`; the ball's `w` along and across the hole by
/// `l_g` and `c_r`, its velocities by `ω₁` times those; the spin by `ω₁ c_r / r`. The first
/// perturbation is along the bar's coordinates (so that a resting ball is not pushed into its
/// wall); the ball is projected into the hole before each interval. `p.scales` is not used.
pub fn max_lyapunov_two_plane(
    sys: &TwoPlaneSystem,
    start: &TwoPlaneStart,
    method: TwoPlaneMethod,
    settings: &RunSettings,
    p: &crate::analysis::lyapunov::LyapunovParams,
) -> Result<crate::analysis::lyapunov::LyapunovResult, SimError> {
    use crate::analysis::lyapunov::{check_params, diverge};
    sys.validate()?;
    check_params(p)?;
    crate::solver::two_plane_rk4::check_start(sys, start)?;
    let w1 = sys.bar.omega1_rad_s();
    let k = match &sys.bar {
        TwoPlaneBar::Lumped(b) => b.stiffness_n_per_m[0].min(b.stiffness_n_per_m[1]),
        TwoPlaneBar::Round(m) => 1.0 / m.tip_compliance_of_first(m.len()),
        TwoPlaneBar::Measured(p) => p
            .modes
            .iter()
            .map(|m| 1.0 / m.tip_compliance_of_first(m.len()))
            .fold(f64::INFINITY, f64::min),
    };
    let su = if sys.forcing.amplitude_n > 0.0 {
        sys.forcing.amplitude_n / k
    } else {
        1e-6
    };
    let clr = [sys.hole.half_axial_gap_m(), sys.radial_clearance_m()];
    let tr = TwoPlaneTrajectories {
        sys,
        method,
        settings: *settings,
        scales: [
            su,
            su,
            w1 * su,
            w1 * su,
            clr[0],
            clr[1],
            w1 * clr[0],
            w1 * clr[1],
            w1 * clr[1] / sys.ball.radius_m,
        ],
        clr,
    };
    // A hole without radial clearance has no motion across it to scale.
    crate::params::positive("radial clearance (hole diameter − ball diameter)/2", clr[1])?;
    diverge(&tr, &(0.0, *start), p)
}

/// The two-plane bar's trajectories for [`max_lyapunov_two_plane`]: a state is its time and
/// the state a start takes.
struct TwoPlaneTrajectories<'a> {
    sys: &'a TwoPlaneSystem,
    method: TwoPlaneMethod,
    settings: RunSettings,
    /// `u_x, u_y, u̇_x, u̇_y, w_a, w_n, ẇ_a, ẇ_n, spin`.
    scales: [f64; 9],
    clr: [f64; 2],
}

impl crate::analysis::lyapunov::Trajectories for TwoPlaneTrajectories<'_> {
    type State = (f64, TwoPlaneStart);

    fn dims(&self) -> usize {
        9
    }

    fn has_ball(&self) -> bool {
        true
    }

    fn direction(&self) -> Vec<f64> {
        let mut e = vec![0.0; 9];
        e[..4].fill(0.5);
        e
    }

    fn to_scaled(&self, s: &Self::State) -> Vec<f64> {
        let st = &s.1;
        let v = [
            st.u_m[0],
            st.u_m[1],
            st.du_m_s[0],
            st.du_m_s[1],
            st.w_hole_m[0],
            st.w_hole_m[1],
            st.dw_hole_m_s[0],
            st.dw_hole_m_s[1],
            st.spin_rad_s,
        ];
        v.iter().zip(&self.scales).map(|(x, s)| x / s).collect()
    }

    fn unscaled(&self, t_s: f64, y: &[f64]) -> Self::State {
        let v: Vec<f64> = y.iter().zip(&self.scales).map(|(x, s)| x * s).collect();
        (
            t_s,
            TwoPlaneStart {
                u_m: [v[0], v[1]],
                du_m_s: [v[2], v[3]],
                w_hole_m: [v[4], v[5]],
                dw_hole_m_s: [v[6], v[7]],
                spin_rad_s: v[8],
            },
        )
    }

    fn drop_ball(&self, _s: &mut Self::State) {}

    fn clamp(&self, s: &mut Self::State) -> bool {
        let mut moved = false;
        for (w, c) in s.1.w_hole_m.iter_mut().zip(self.clr) {
            if w.abs() > c {
                *w = w.signum() * c;
                moved = true;
            }
        }
        moved
    }

    fn run(&self, s: &Self::State, t_end_s: f64) -> Result<Self::State, SimError> {
        let settings = RunSettings {
            duration_s: t_end_s - s.0,
            ..self.settings
        };
        let r = self
            .method
            .run_from(self.sys, &s.1, s.0, &settings, &mut |_| {}, None)?;
        Ok((t_end_s, r.end))
    }

    fn t_s(s: &Self::State) -> f64 {
        s.0
    }
}

/// The stroboscopic (Poincaré) section of one two-plane run from `start`: the state at every
/// `t_k = φ/Ω + k·T` with `after_s ≤ t_k ≤ duration_s` (`phase_rad` modulo 2π), the sample
/// times computed from `k` as in [`Stroboscope`](super::poincare::Stroboscope). The number of
/// points is checked before anything runs.
pub fn poincare_two_plane(
    sys: &TwoPlaneSystem,
    start: &TwoPlaneStart,
    method: TwoPlaneMethod,
    settings: &RunSettings,
    phase_rad: f64,
    after_s: f64,
) -> Result<Vec<TwoPlaneSample>, SimError> {
    let period_s = 2.0 * std::f64::consts::PI / sys.omega_rad_s();
    let first_s =
        super::poincare::Stroboscope::new(period_s, phase_rad, after_s, f64::INFINITY).next_t_s();
    crate::limits::check_samples(
        "Poincaré points = (duration − transient) / forcing period",
        (settings.duration_s - first_s).max(0.0),
        period_s,
    )?;
    let mut points = Vec::new();
    let mut on_sample = |s: &TwoPlaneSample| points.push(*s);
    method.run_from(
        sys,
        start,
        0.0,
        settings,
        &mut |_| {},
        Some(Sampling {
            start_s: first_s,
            interval_s: period_s,
            on_sample: &mut on_sample,
        }),
    )?;
    Ok(points)
}

/// RMS along the force of the bar without its ball, from rest: the reference of a reduction.
pub fn solid_rms_m(sys: &TwoPlaneSystem, settings: &RunSettings) -> Result<f64, SimError> {
    let mut bare = one_plane_system(sys, FrictionModel::None);
    bare.damper = None;
    one_plane_rms_m(&bare, &State::REST, settings)
}

/// RMS of the bar over the window of a one-plane exact run (the solid bar when `sys` has no
/// ball).
pub fn one_plane_rms_m(
    sys: &System,
    init: &State,
    settings: &RunSettings,
) -> Result<f64, SimError> {
    struct Nothing;
    impl Observer for Nothing {}
    Ok(run_case(sys, init, settings, &Exact::default(), &mut Nothing)?.rms_m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::two_plane::{Gravity, Hole, PlanarBall, PlanarBar, PlanarForcing};
    use crate::params::Frequency;

    fn sys() -> TwoPlaneSystem {
        TwoPlaneSystem {
            bar: PlanarBar::isotropic(&Bar::PAPER_CAVITY).into(),
            ball: PlanarBall::paper_frictionless(),
            hole: Hole {
                angle_deg: 0.0,
                axial_gap_m: 1e-3,
                diameter_m: 0.0151,
            },
            forcing: PlanarForcing {
                amplitude_n: 15.0,
                frequency: Frequency::Ratio(1.0),
                angle_deg: 63.4,
            },
            gravity: Gravity::default(),
            bar_diameter_m: None,
        }
    }

    #[test]
    fn members_start_on_the_floor_inside_the_gap_and_are_reproducible() {
        let s = sys();
        let ens = TwoPlaneEnsemble::default();
        let a = starts(&s, &ens).unwrap();
        assert_eq!(a, starts(&s, &ens).unwrap());
        assert_eq!(a.len(), 8);
        assert!(a[0].w_hole_m[0].abs() < 1e-300);
        for m in &a {
            assert!(m.w_hole_m[0].abs() <= 0.5e-3);
            assert!((m.w_hole_m[1] - s.radial_clearance_m()).abs() < 1e-18);
            assert!(m.dw_hole_m_s[0].abs() <= 0.01);
            // Across the hole: away from the wall it rests on.
            assert!(m.dw_hole_m_s[1] * m.w_hole_m[1] <= 0.0 && m.dw_hole_m_s[1].abs() <= 0.01);
        }
        assert!(a[1..].iter().all(|m| m.dw_hole_m_s[1] != 0.0));
        assert!(a[1..].iter().all(|m| m.dw_hole_m_s[0].abs() > 0.0));
        let bad = TwoPlaneEnsemble { members: 0, ..ens };
        assert!(starts(&s, &bad)
            .unwrap_err()
            .to_string()
            .contains("--members"));
    }

    #[test]
    fn spread_of_known_values() {
        let s = Spread::of(&[1.0, 2.0, 3.0, 4.0]);
        assert!((s.mean - 2.5).abs() < 1e-15);
        // s² = 5/3, s/√4.
        assert!((s.std_err - (5.0f64 / 3.0).sqrt() / 2.0).abs() < 1e-15);
        assert!((s.min - 1.0).abs() < 1e-15 && (s.max - 4.0).abs() < 1e-15 && s.n == 4);
    }
}
