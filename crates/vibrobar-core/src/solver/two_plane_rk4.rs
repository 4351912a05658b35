//! The reference solver of the bar that bends in two planes: classical RK4 with every event
//! located inside its step, and a resting-contact mode per wall.
//!
//! The model ([`crate::params::two_plane`]): a lumped bar `M ü + C u̇ + K u = F0 sin(Ωt)·e_F`
//! in the cross-section plane (`u = (u_x, u_y)`, `K` and `C` may differ along two principal
//! axes), and the ball (absolute position `b`) in a box in the hole's frame: `±l_g` along the
//! hole (`a`), `±c_r` across it (`n`), with gravity `g` on the ball.
//!
//! # Method
//! Fixed steps on the grid `i·dt` (the window's start is a step end too). After each step the
//! guards of the current mode are evaluated; if one has crossed, the earliest crossing is found
//! by the Illinois method on the guard of the RK4 step of length `τ ∈ (0, dt]` from the step's
//! start (each trial is a fresh RK4 step, so the event state carries RK4's accuracy), the run
//! goes to it, applies the event and goes on to the next grid point. Work integrals (forcing,
//! viscous, and `∫u²` over the window) are extra components of the state, integrated by the same
//! RK4 steps.
//!
//! # Modes and events
//! The ball flies, or rests on a wall (on one of each pair of walls at most: on a plug, on the
//! hole's wall, or in a corner). The walls are frictionless here, so along a wall the ball
//! slides freely and its spin never changes.
//! - **Impact** at wall `n` (unit normal from the ball's centre to the wall) with approach speed
//!   `v_n = (v̇ − u̇)·n > 0`: [`crate::damper::wall_impact`] with `μ = 0`, i.e. the one-plane law
//!   along `n`.
//! - **Coming to rest.** After an impact the ball would fly back within `2e·v_n/a_p`, where
//!   `a_p = (g − f/M)·n` is the relative acceleration pressing it on the wall (`f` the force on
//!   the bar besides the ball). When that is shorter than one step, the remaining geometric
//!   sequence of bounces (which lasts at most `dt/(1 − e)`) is summed to its limit, the plastic
//!   one: bar and ball take the common normal velocity, and the ball rests on the wall.
//! - **Resting** on wall `n`: the ball moves with the bar along `n`, pressed by the normal force
//!   `N = m_d M/(M + m_d)·(g·n − f·n/M)`, which the bar feels as well.
//! - **Lift-off** where `N` falls to zero: the ball flies again.
//!
//! The paper's RK4 cannot serve as this check: it counts a resting ball as one impact per step.
//! A crossing that enters and leaves a wall within one step is not seen (its depth is below
//! `(v_n·dt)²/…`, far below the clearances at `dt = 1 µs`).

use crate::damper::wall_impact::{inverse_mass_normal_per_kg, wall_impact};
use crate::error::{EventLimitCause, ParamError, SimError};
use crate::limits;
use crate::params::two_plane::{direction, TwoPlaneSystem};
use crate::params::RunSettings;

/// The walls of the box, as indices into [`TwoPlaneSummary::impacts`] and
/// [`TwoPlaneSummary::rest_fraction`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum HoleWall {
    /// The end plug at `+l_g` along the hole.
    AxialPlus = 0,
    /// The end plug at `−l_g`.
    AxialMinus = 1,
    /// The hole's wall at `+c_r` across the hole.
    AcrossPlus = 2,
    /// The hole's wall at `−c_r`.
    AcrossMinus = 3,
}

impl HoleWall {
    /// All walls, in index order.
    pub const ALL: [HoleWall; 4] = [
        HoleWall::AxialPlus,
        HoleWall::AxialMinus,
        HoleWall::AcrossPlus,
        HoleWall::AcrossMinus,
    ];

    /// `0` along the hole, `1` across it.
    pub fn axis(self) -> usize {
        self as usize / 2
    }

    /// `+1` or `−1`.
    pub fn sign(self) -> f64 {
        if self as usize % 2 == 0 {
            1.0
        } else {
            -1.0
        }
    }

    fn of(axis: usize, sign: f64) -> HoleWall {
        HoleWall::ALL[2 * axis + usize::from(sign < 0.0)]
    }
}

/// What happened at an event.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TwoPlaneEventKind {
    /// The ball hit a wall at approach speed `approach_m_s`.
    Impact {
        /// The wall.
        wall: HoleWall,
        /// `(v̇ − u̇)·n` before.
        approach_m_s: f64,
        /// Kinetic energy lost.
        energy_loss_j: f64,
    },
    /// A bounce sequence was summed to its end: the ball now rests on the wall.
    Rest {
        /// The wall.
        wall: HoleWall,
        /// Kinetic energy the summed bounces removed.
        energy_loss_j: f64,
    },
    /// The normal force fell to zero: the ball leaves the wall.
    LiftOff {
        /// The wall.
        wall: HoleWall,
    },
}

/// One event.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TwoPlaneEvent {
    /// Time.
    pub t_s: f64,
    /// What happened.
    pub kind: TwoPlaneEventKind,
}

/// Where a run starts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TwoPlaneStart {
    /// Bar displacement `(u_x, u_y)`.
    pub u_m: [f64; 2],
    /// Bar velocity.
    pub du_m_s: [f64; 2],
    /// The ball relative to the cavity's centre, `[along the hole, across it]`.
    pub w_hole_m: [f64; 2],
    /// Its velocity relative to the bar, `[along, across]`.
    pub dw_hole_m_s: [f64; 2],
    /// Spin about the bar's axis.
    pub spin_rad_s: f64,
}

impl TwoPlaneStart {
    /// The bar at rest, the ball at rest at `w_hole_m` (put on the walls it lies on).
    pub fn at_rest(w_hole_m: [f64; 2]) -> TwoPlaneStart {
        TwoPlaneStart {
            u_m: [0.0; 2],
            du_m_s: [0.0; 2],
            w_hole_m,
            dw_hole_m_s: [0.0; 2],
            spin_rad_s: 0.0,
        }
    }

    /// The bar at rest, the ball at rest on the walls gravity presses it onto, at
    /// `along_m` along the hole where gravity has no component along it.
    pub fn resting(sys: &TwoPlaneSystem, along_m: f64) -> TwoPlaneStart {
        let g = sys.gravity.m_s2;
        let rel = (sys.gravity.angle_deg - sys.hole.angle_deg).to_radians();
        let (g_n, g_a) = (g * rel.sin(), g * rel.cos());
        let clr = [sys.hole.half_axial_gap_m(), sys.radial_clearance_m()];
        let pick = |gc: f64, c: f64, free: f64| {
            if gc.abs() > 1e-12 * g.max(1e-300) {
                c * gc.signum()
            } else {
                free
            }
        };
        TwoPlaneStart::at_rest([pick(g_a, clr[0], along_m), pick(g_n, clr[1], 0.0)])
    }
}

/// The energy book of a run: `ΔE = W_F − W_C − W_impact` with
/// `E = ½M|u̇|² + ½uᵀKu + ½m_d|v̇|² + ½Iω² − m_d g·b`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TwoPlaneBook {
    /// Work of the harmonic force.
    pub forcing_work_j: f64,
    /// Viscous loss of the bar.
    pub viscous_loss_j: f64,
    /// Kinetic energy lost in impacts and summed bounce sequences.
    pub impact_loss_j: f64,
    /// `E(end) − E(start)`.
    pub energy_change_j: f64,
}

impl TwoPlaneBook {
    /// `W_F − W_C − W_impact − ΔE` (zero up to the integration error).
    pub fn residual_j(&self) -> f64 {
        self.forcing_work_j - self.viscous_loss_j - self.impact_loss_j - self.energy_change_j
    }
}

/// What a run reports. RMS values and fractions are over the window (the last
/// `rms_fraction` of the run); counts and the book over the whole run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TwoPlaneSummary {
    /// RMS of the bar's displacement along the force, `u·e_F`.
    pub rms_along_force_m: f64,
    /// RMS of `u_x` (radial) and `u_y` (tangential).
    pub rms_m: [f64; 2],
    /// RMS of `|u| = √(u_x² + u_y²)`.
    pub rms_total_m: f64,
    /// Impacts per wall ([`HoleWall`] order).
    pub impacts: [u64; 4],
    /// Fraction of the window the ball rests on each wall (a corner counts for both).
    pub rest_fraction: [f64; 4],
    /// Fraction of the window the ball flies (touches no wall).
    pub flight_fraction: f64,
    /// Every event of the run.
    pub events: u64,
    /// Largest depth the ball reached beyond a wall (≤ 0: never beyond).
    pub max_penetration_m: f64,
    /// The energy book.
    pub book: TwoPlaneBook,
    /// The state at the end.
    pub end: TwoPlaneStart,
}

/// The reference solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TwoPlaneRk4 {
    /// The grid step.
    pub dt_s: f64,
}

impl Default for TwoPlaneRk4 {
    fn default() -> Self {
        TwoPlaneRk4 { dt_s: 1e-6 }
    }
}

/// The solver runs frictionless walls only.
pub const TWO_PLANE_RK4_FRICTIONLESS: &str = "the two-plane reference solver runs frictionless walls: set ball.friction_static, ball.friction_kinetic and ball.rolling_friction_m to 0";

/// Events allowed per grid step on average before a run is stopped.
const EVENTS_PER_STEP: f64 = 4.0;

// State layout: u (0, 1), u̇ (2, 3), b (4, 5), ḃ (6, 7), then the integrals: forcing work,
// viscous loss, and over the window ∫(u·e_F)², ∫u_x², ∫u_y².
const NY: usize = 13;
type Y = [f64; NY];

fn dot(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

fn mat(m: &[[f64; 2]; 2], v: [f64; 2]) -> [f64; 2] {
    [
        m[0][0] * v[0] + m[0][1] * v[1],
        m[1][0] * v[0] + m[1][1] * v[1],
    ]
}

/// Which wall the ball rests on, per axis: `0` none, `±1` the wall at `±` clearance.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
struct Rest([i8; 2]);

struct Model {
    m: f64,
    md: f64,
    /// `m_d M / (M + m_d)`.
    red: f64,
    k: [[f64; 2]; 2],
    c: [[f64; 2]; 2],
    f0: f64,
    om: f64,
    e_f: [f64; 2],
    g: [f64; 2],
    /// The hole's axes `a` (along) and `n` (across).
    axes: [[f64; 2]; 2],
    /// `l_g`, `c_r`.
    clr: [f64; 2],
    e: f64,
    inertia: f64,
    /// Guard tolerances: depth beyond a wall, tension on a wall.
    tol_x: f64,
    tol_f: f64,
}

impl Model {
    fn new(sys: &TwoPlaneSystem) -> Model {
        let (m, md) = (sys.bar.mass_kg, sys.ball.mass_kg);
        let (k, c) = sys.bar.matrices();
        let clr = [sys.hole.half_axial_gap_m(), sys.radial_clearance_m()];
        let g_abs = sys.gravity.m_s2;
        let gd = direction(sys.gravity.angle_deg);
        Model {
            m,
            md,
            red: m * md / (m + md),
            k,
            c,
            f0: sys.forcing.amplitude_n,
            om: sys.omega_rad_s(),
            e_f: direction(sys.forcing.angle_deg),
            g: [g_abs * gd[0], g_abs * gd[1]],
            axes: [
                direction(sys.hole.angle_deg),
                direction(sys.hole.angle_deg + 90.0),
            ],
            clr,
            e: sys.ball.restitution,
            inertia: sys.ball.inertia_kg_m2(),
            tol_x: 1e-12 * clr[0].min(clr[1]).max(1e-300),
            tol_f: 1e-13 * md * (g_abs + sys.forcing.amplitude_n.abs() / m).max(1e-300),
        }
    }

    /// The force on the bar besides the ball's, `F0 sin Ωt e_F − C u̇ − K u`.
    fn bar_force(&self, t: f64, y: &Y) -> [f64; 2] {
        let fs = self.f0 * (self.om * t).sin();
        let cu = mat(&self.c, [y[2], y[3]]);
        let ku = mat(&self.k, [y[0], y[1]]);
        [
            fs * self.e_f[0] - cu[0] - ku[0],
            fs * self.e_f[1] - cu[1] - ku[1],
        ]
    }

    /// The outward normal of the wall the ball rests on along `axis` with sign `s`.
    fn normal(&self, axis: usize, s: f64) -> [f64; 2] {
        [s * self.axes[axis][0], s * self.axes[axis][1]]
    }

    /// Normal force on a ball resting on the wall with outward normal `n`.
    fn normal_force(&self, f: [f64; 2], n: [f64; 2]) -> f64 {
        self.red * (dot(self.g, n) - dot(f, n) / self.m)
    }

    fn deriv(&self, t: f64, y: &Y, rest: Rest, win: f64) -> Y {
        let f = self.bar_force(t, y);
        let mut ddu = [f[0] / self.m, f[1] / self.m];
        let mut ddb = self.g;
        for axis in 0..2 {
            let s = rest.0[axis];
            if s != 0 {
                let n = self.normal(axis, f64::from(s));
                let nf = self.normal_force(f, n);
                for i in 0..2 {
                    ddu[i] += nf * n[i] / self.m;
                    ddb[i] -= nf * n[i] / self.md;
                }
            }
        }
        let du = [y[2], y[3]];
        let fs = self.f0 * (self.om * t).sin();
        let uf = y[0] * self.e_f[0] + y[1] * self.e_f[1];
        [
            y[2],
            y[3],
            ddu[0],
            ddu[1],
            y[6],
            y[7],
            ddb[0],
            ddb[1],
            fs * dot(self.e_f, du),
            dot(du, mat(&self.c, du)),
            win * uf * uf,
            win * y[0] * y[0],
            win * y[1] * y[1],
        ]
    }

    fn step(&self, t: f64, y: &Y, h: f64, rest: Rest, win: f64) -> Y {
        let add = |a: &Y, k: &Y, s: f64| {
            let mut o = *a;
            for i in 0..NY {
                o[i] += s * k[i];
            }
            o
        };
        let k1 = self.deriv(t, y, rest, win);
        let k2 = self.deriv(t + 0.5 * h, &add(y, &k1, 0.5 * h), rest, win);
        let k3 = self.deriv(t + 0.5 * h, &add(y, &k2, 0.5 * h), rest, win);
        let k4 = self.deriv(t + h, &add(y, &k3, h), rest, win);
        let mut o = *y;
        for i in 0..NY {
            o[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
        o
    }

    /// The ball relative to the cavity's centre along `axis`.
    fn w(&self, y: &Y, axis: usize) -> f64 {
        dot([y[4] - y[0], y[5] - y[1]], self.axes[axis])
    }

    /// The guards, positive once crossed: the depth beyond a wall the ball flies towards, the
    /// tension on a wall it rests on; `−∞` where none applies.
    fn guards(&self, t: f64, y: &Y, rest: Rest) -> [f64; 4] {
        let mut out = [f64::NEG_INFINITY; 4];
        let f = self.bar_force(t, y);
        for axis in 0..2 {
            let s = rest.0[axis];
            if s == 0 {
                let w = self.w(y, axis);
                out[2 * axis] = w - self.clr[axis] - self.tol_x;
                out[2 * axis + 1] = -w - self.clr[axis] - self.tol_x;
            } else {
                let s = f64::from(s);
                let n = self.normal(axis, s);
                out[HoleWall::of(axis, s) as usize] = -self.normal_force(f, n) - self.tol_f;
            }
        }
        out
    }

    /// Put the ball exactly on the wall of `axis` at sign `s` (its position only).
    fn snap(&self, y: &mut Y, axis: usize, s: f64) {
        let d = s * self.clr[axis] - self.w(y, axis);
        y[4] += d * self.axes[axis][0];
        y[5] += d * self.axes[axis][1];
    }

    /// Remove the ball's velocity relative to the bar along `axis` (a resting ball).
    fn hold(&self, y: &mut Y, axis: usize) {
        let a = self.axes[axis];
        let dw = dot([y[6] - y[2], y[7] - y[3]], a);
        y[6] -= dw * a[0];
        y[7] -= dw * a[1];
    }

    fn energy(&self, y: &Y, spin: f64) -> f64 {
        let u = [y[0], y[1]];
        0.5 * self.m * (y[2] * y[2] + y[3] * y[3])
            + 0.5 * dot(u, mat(&self.k, u))
            + 0.5 * self.md * (y[6] * y[6] + y[7] * y[7])
            + 0.5 * self.inertia * spin * spin
            - self.md * dot(self.g, [y[4], y[5]])
    }

    /// A normal impulse `p` on the ball along `−n`, and on the bar along `n`.
    fn impulse(&self, y: &mut Y, n: [f64; 2], p: f64) {
        for i in 0..2 {
            y[6 + i] -= p / self.md * n[i];
            y[2 + i] += p / self.m * n[i];
        }
    }
}

impl TwoPlaneRk4 {
    /// Run `sys` from `start` over `settings.duration_s` on steps of `self.dt_s` (the
    /// settings' `dt_s` is not used), calling `on_event` at every event.
    pub fn run(
        &self,
        sys: &TwoPlaneSystem,
        start: &TwoPlaneStart,
        settings: &RunSettings,
        on_event: &mut dyn FnMut(&TwoPlaneEvent),
    ) -> Result<TwoPlaneSummary, SimError> {
        sys.validate()?;
        settings.validate()?;
        if !sys.ball.frictionless() {
            return Err(SimError::Unsupported(TWO_PLANE_RK4_FRICTIONLESS));
        }
        let h = self.dt_s;
        crate::params::positive("dt_s", h)?;
        let k_max = sys.bar.stiffness_n_per_m[0].max(sys.bar.stiffness_n_per_m[1]);
        let omega_max = (k_max / sys.bar.mass_kg).sqrt();
        limits::check_derived(
            "ω_max·dt_s (the bar's higher principal frequency times the step)",
            || format!("{omega_max} rad/s · {h} s"),
            omega_max * h,
            0.0,
            limits::RK4_MAX_OMEGA_DT,
            "take a smaller step",
        )?;
        let duration = settings.duration_s;
        let steps = limits::check_derived(
            "duration_s / dt_s (steps)",
            || format!("{duration} s / {h} s"),
            duration / h,
            0.0,
            limits::MAX_STEPS,
            "shorten the run or take a larger step",
        )?;
        limits::check_phase(sys.omega_rad_s().max(omega_max), duration)?;
        let md = Model::new(sys);
        for (axis, field) in [(0, "start.w_hole_m[0]"), (1, "start.w_hole_m[1]")] {
            crate::params::in_range(
                field,
                start.w_hole_m[axis],
                -md.clr[axis],
                md.clr[axis],
                "[−clearance, +clearance] (l_g along the hole, c_r across it)",
            )?;
        }
        for (v, field) in [
            (start.u_m[0], "start.u_m[0]"),
            (start.u_m[1], "start.u_m[1]"),
            (start.du_m_s[0], "start.du_m_s[0]"),
            (start.du_m_s[1], "start.du_m_s[1]"),
            (start.dw_hole_m_s[0], "start.dw_hole_m_s[0]"),
            (start.dw_hole_m_s[1], "start.dw_hole_m_s[1]"),
            (start.spin_rad_s, "start.spin_rad_s"),
        ] {
            crate::params::finite(field, v)?;
        }

        // The start, in absolute coordinates.
        let [a, n] = md.axes;
        let w = [
            start.w_hole_m[0] * a[0] + start.w_hole_m[1] * n[0],
            start.w_hole_m[0] * a[1] + start.w_hole_m[1] * n[1],
        ];
        let dw = [
            start.dw_hole_m_s[0] * a[0] + start.dw_hole_m_s[1] * n[0],
            start.dw_hole_m_s[0] * a[1] + start.dw_hole_m_s[1] * n[1],
        ];
        let mut y: Y = [0.0; NY];
        y[0] = start.u_m[0];
        y[1] = start.u_m[1];
        y[2] = start.du_m_s[0];
        y[3] = start.du_m_s[1];
        y[4] = y[0] + w[0];
        y[5] = y[1] + w[1];
        y[6] = y[2] + dw[0];
        y[7] = y[3] + dw[1];
        let spin = start.spin_rad_s;
        let e0 = md.energy(&y, spin);

        // A ball at rest on a wall that presses it stays there.
        let mut rest = Rest::default();
        let f = md.bar_force(0.0, &y);
        for axis in 0..2 {
            let wa = start.w_hole_m[axis];
            let s = wa.signum();
            let on_wall = (wa.abs() - md.clr[axis]).abs() <= md.tol_x;
            if on_wall && start.dw_hole_m_s[axis] == 0.0 {
                let nrm = md.normal(axis, s);
                if md.normal_force(f, nrm) > 0.0 {
                    rest.0[axis] = s as i8;
                }
            }
        }

        let t_end = duration;
        let t_win = duration * (1.0 - settings.rms_fraction);
        let max_events = (EVENTS_PER_STEP * steps).max(1e4) as u64;
        let mut t = 0.0_f64;
        let mut grid = 0.0_f64;
        let mut out = TwoPlaneSummary {
            rms_along_force_m: 0.0,
            rms_m: [0.0; 2],
            rms_total_m: 0.0,
            impacts: [0; 4],
            rest_fraction: [0.0; 4],
            flight_fraction: 0.0,
            events: 0,
            max_penetration_m: f64::NEG_INFINITY,
            book: TwoPlaneBook::default(),
            end: *start,
        };
        let mut loss = 0.0;
        let mut rest_time = [0.0; 4];
        let mut flight_time = 0.0;

        while t < t_end {
            // The next grid point (the window's start and the end are grid points too).
            while grid * h <= t {
                grid += 1.0;
            }
            let mut t_next = (grid * h).min(t_end);
            if t < t_win && t_next > t_win {
                t_next = t_win;
            }
            let win = if t >= t_win { 1.0 } else { 0.0 };
            let span = t_next - t;
            let y1 = md.step(t, &y, span, rest, win);
            let g1 = md.guards(t_next, &y1, rest);
            let crossed = g1.iter().any(|&g| g > 0.0);
            let (tau, y_new, hit) = if crossed {
                let g0 = md.guards(t, &y, rest);
                let mut best = (span, usize::MAX);
                for k in 0..4 {
                    if g1[k] > 0.0 {
                        let tk = if g0[k] >= 0.0 {
                            0.0
                        } else {
                            let guard =
                                |tau| md.guards(t + tau, &md.step(t, &y, tau, rest, win), rest)[k];
                            locate(guard, g0[k], span, g1[k])
                        };
                        if tk < best.0 || best.1 == usize::MAX {
                            best = (tk, k);
                        }
                    }
                }
                let yk = if best.0 > 0.0 {
                    md.step(t, &y, best.0, rest, win)
                } else {
                    y
                };
                (best.0, yk, Some(best.1))
            } else {
                (span, y1, None)
            };
            // Time per mode over the window.
            if win > 0.0 {
                if rest.0 == [0; 2] {
                    flight_time += tau;
                }
                for axis in 0..2 {
                    if rest.0[axis] != 0 {
                        rest_time[HoleWall::of(axis, f64::from(rest.0[axis])) as usize] += tau;
                    }
                }
            }
            t = if hit.is_some() { t + tau } else { t_next };
            y = y_new;
            for axis in 0..2 {
                if rest.0[axis] != 0 {
                    md.snap(&mut y, axis, f64::from(rest.0[axis]));
                    md.hold(&mut y, axis);
                } else {
                    out.max_penetration_m = out
                        .max_penetration_m
                        .max(md.w(&y, axis).abs() - md.clr[axis]);
                }
            }
            if !y.iter().all(|v| v.is_finite()) {
                return Err(ParamError::NonFiniteResult {
                    quantity: "two-plane state",
                    value: y
                        .iter()
                        .copied()
                        .find(|v| !v.is_finite())
                        .unwrap_or(f64::NAN),
                    cause: "a step too large for the bar, or extreme inputs",
                }
                .into());
            }
            let Some(k) = hit else { continue };
            let wall = HoleWall::ALL[k];
            let (axis, s) = (wall.axis(), wall.sign());
            md.snap(&mut y, axis, s);
            let kind = if f64::from(rest.0[axis]) * s > 0.0 {
                rest.0[axis] = 0;
                TwoPlaneEventKind::LiftOff { wall }
            } else {
                let nrm = md.normal(axis, s);
                let approach = dot([y[6] - y[2], y[7] - y[3]], nrm).max(0.0);
                let w_nn = inverse_mass_normal_per_kg(md.md, md.m);
                let p = wall_impact(approach, 0.0, w_nn, 1.0, md.e, 0.0);
                md.impulse(&mut y, nrm, p.normal_n_s);
                let lost = 0.5 * md.red * (1.0 - md.e * md.e) * approach * approach;
                loss += lost;
                out.impacts[k] += 1;
                on_event(&TwoPlaneEvent {
                    t_s: t,
                    kind: TwoPlaneEventKind::Impact {
                        wall,
                        approach_m_s: approach,
                        energy_loss_j: lost,
                    },
                });
                out.events += 1;
                // Sum the bounces to their end if the next one would be shorter than a step.
                let press = md.normal_force(md.bar_force(t, &y), nrm) / md.red;
                let recede = md.e * approach;
                if press > 0.0 && 2.0 * recede < press * h {
                    let rel = dot([y[6] - y[2], y[7] - y[3]], nrm);
                    md.impulse(&mut y, nrm, rel / w_nn);
                    let lost = 0.5 * md.red * rel * rel;
                    loss += lost;
                    rest.0[axis] = s as i8;
                    md.hold(&mut y, axis);
                    TwoPlaneEventKind::Rest {
                        wall,
                        energy_loss_j: lost,
                    }
                } else {
                    continue_event_count(&out, t, max_events, sys)?;
                    continue;
                }
            };
            on_event(&TwoPlaneEvent { t_s: t, kind });
            out.events += 1;
            continue_event_count(&out, t, max_events, sys)?;
        }

        let t_w = t_end - t_win;
        out.rms_along_force_m = (y[10] / t_w).sqrt();
        out.rms_m = [(y[11] / t_w).sqrt(), (y[12] / t_w).sqrt()];
        out.rms_total_m = ((y[11] + y[12]) / t_w).sqrt();
        out.flight_fraction = flight_time / t_w;
        out.rest_fraction = rest_time.map(|r| r / t_w);
        out.book = TwoPlaneBook {
            forcing_work_j: y[8],
            viscous_loss_j: y[9],
            impact_loss_j: loss,
            energy_change_j: md.energy(&y, spin) - e0,
        };
        let w = [y[4] - y[0], y[5] - y[1]];
        let dw = [y[6] - y[2], y[7] - y[3]];
        out.end = TwoPlaneStart {
            u_m: [y[0], y[1]],
            du_m_s: [y[2], y[3]],
            w_hole_m: [dot(w, a), dot(w, n)],
            dw_hole_m_s: [dot(dw, a), dot(dw, n)],
            spin_rad_s: spin,
        };
        Ok(out)
    }
}

/// Stop a run whose events exceed `max_events`.
fn continue_event_count(
    out: &TwoPlaneSummary,
    t: f64,
    max_events: u64,
    sys: &TwoPlaneSystem,
) -> Result<(), SimError> {
    if out.events > max_events {
        let period = 2.0 * std::f64::consts::PI / sys.omega_rad_s();
        return Err(SimError::TooManyEvents {
            limit: max_events,
            t_s: t,
            events_per_period: out.events as f64 / (t / period).max(1.0),
            cause: EventLimitCause::Dense,
        });
    }
    Ok(())
}

/// The first `τ ∈ (0, hi]` where `g(τ)` crosses zero, with `g(0) = g_lo < 0 < g(hi) = g_hi`
/// (Illinois), to about `1e-15·hi`.
fn locate(g: impl Fn(f64) -> f64, g_lo: f64, hi: f64, g_hi: f64) -> f64 {
    let (mut a, mut fa, mut b, mut fb) = (0.0, g_lo, hi, g_hi);
    let mut side = 0i8;
    for _ in 0..200 {
        if b - a <= 1e-15 * hi.max(1e-300) {
            break;
        }
        let c = (a * fb - b * fa) / (fb - fa);
        let c = if c > a && c < b { c } else { 0.5 * (a + b) };
        let fc = g(c);
        if fc > 0.0 {
            b = c;
            fb = fc;
            if side == 1 {
                fa *= 0.5;
            }
            side = 1;
        } else {
            a = c;
            fa = fc;
            if side == -1 {
                fb *= 0.5;
            }
            side = -1;
        }
    }
    b
}
