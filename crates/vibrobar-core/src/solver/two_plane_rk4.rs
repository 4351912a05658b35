//! The reference solver of the bar that bends in two planes: classical RK4 with every event
//! located inside its step, and a resting-contact mode per wall with rolling, sliding and
//! sticking.
//!
//! The model ([`crate::params::two_plane`]): a lumped bar `M ü + C u̇ + K u = F0 sin(Ωt)·e_F`
//! in the cross-section plane (`u = (u_x, u_y)`, `K` and `C` may differ along two principal
//! axes), and the ball (absolute position `b`, spin `ω` about the bar's axis, `I = 2/5·m_d r²`)
//! in a box in the hole's frame: `±l_g` along the hole (`a`), `±c_r` across it (`n`), with
//! gravity `g` on the ball.
//!
//! # Method
//! Fixed steps on the grid `i·dt` (the window's start is a step end too). After each step the
//! guards of the current mode are evaluated; if one has crossed, the earliest crossing is found
//! by the Illinois method on the guard of the RK4 step of length `τ ∈ (0, dt]` from the step's
//! start (each trial is a fresh RK4 step, so the event state carries RK4's accuracy), the run
//! goes to it, applies the event and goes on to the next grid point. Work integrals (forcing,
//! viscous, sliding and rolling losses, and `∫u²` over the window) are extra components of the
//! state, integrated by the same RK4 steps.
//!
//! # Modes
//! The ball flies, rests on one wall, or sits in a corner (a plug and the hole's wall). On a wall
//! with outward normal `n` (from the ball's centre) and tangent `t = ẑ × n`, the contact point
//! slips at `σ = (ḃ − u̇)·t + r·ω`.
//! - **Resting on a wall:** the ball moves with the bar along `n`, pressed by the normal force
//!   `N = m_d M/(M + m_d)·(g·n − f·n/M)` (`f` the force on the bar besides the ball's). Along the
//!   wall it
//!   - **rolls** (`σ = 0`) while the friction that needs stays within `μ_s·N`, with a
//!     rolling-resistance torque `η·N` against `ω`: `F_t = −(g·t − f·t/M + r·τ/I)/W_tt`,
//!     `W_tt = 7/(2m_d) + 1/M`, so a ball on a wall accelerating at `ü` lags at `−(5/7)·ü`;
//!   - **slides** at `F_t = −μ_k·N·sgn σ` otherwise (rolling resistance is left out while it
//!     slides);
//!   - **sticks** (`σ = 0`, `ω = 0`) while rolling resistance can hold it: `|r·F_t| ≤ η·N` with
//!     `F_t = −(g·t − f·t/M)/(1/m_d + 1/M)` and `|F_t| ≤ μ_s·N`.
//! - **In a corner** the ball moves with the bar; a spinning ball slides on both walls and its
//!   spin decays, the two normal forces solving the two walls' balance together.
//! - **Lift-off** where a normal force falls to zero.
//!
//! # Impacts
//! At wall `n` with approach speed `v_n = (ḃ − u̇)·n > 0`: [`crate::damper::wall_impact`] (with
//! `μ = μ_k`). A ball resting on the other wall of a corner takes the impulse's tangential
//! part as an approach of that wall, and the law is applied there too, wall by wall, until
//! nothing approaches. After an impact the ball would fly back within `2e·v_n/a_p`, with
//! `a_p = (g − f/M)·n` pressing it on the wall; when that is shorter than one step, the remaining
//! geometric sequence of bounces (at most `dt/(1 − e)` long) is summed to its plastic limit and
//! the ball rests on the wall.
//!
//! The paper's RK4 cannot serve as this check: it counts a resting ball as one impact per step.
//! A crossing that enters and leaves a wall within one step is not seen.

use crate::damper::wall_impact::{
    inverse_mass_normal_per_kg, inverse_mass_tangential_per_kg, wall_impact,
};
use crate::error::{EventLimitCause, ParamError, SimError};
use crate::limits;
use crate::params::two_plane::{direction, PlanarBar, TwoPlaneSystem};
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

    pub(crate) fn of(axis: usize, sign: f64) -> HoleWall {
        HoleWall::ALL[2 * axis + usize::from(sign < 0.0)]
    }
}

/// How a ball resting on a wall moves along it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum WallMotion {
    /// The contact point slips (always, on a frictionless wall).
    Sliding = 0,
    /// The ball rolls without slip.
    Rolling = 1,
    /// The ball neither slips nor rolls: rolling resistance holds it.
    Stuck = 2,
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
        /// Kinetic energy lost (translation and spin).
        energy_loss_j: f64,
    },
    /// A bounce sequence was summed to its end: the ball now rests on the wall.
    Rest {
        /// The wall.
        wall: HoleWall,
        /// Kinetic energy the summed bounces removed.
        energy_loss_j: f64,
    },
    /// The normal force fell to zero (or an impulse on the other wall of a corner pulled the
    /// ball off): the ball leaves the wall.
    LiftOff {
        /// The wall.
        wall: HoleWall,
    },
    /// A ball resting on a wall started to slide, roll or stick.
    Motion {
        /// The wall.
        wall: HoleWall,
        /// How it moves from now on.
        motion: WallMotion,
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
    /// The bar at rest, the ball at rest at `w_hole_m` (on the walls it lies on).
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

/// The state at one time of a sampled run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TwoPlaneSample {
    /// Time.
    pub t_s: f64,
    /// The state then, in the form a start takes.
    pub state: TwoPlaneStart,
}

/// Sampling of a run: the state at `start_s + k·interval_s` (k = 0, 1, …) up to the end, handed
/// to `on_sample` in the order of time. The reference solver ends a step at each sample time.
pub struct Sampling<'a> {
    /// The first sample's time, s (≥ 0).
    pub start_s: f64,
    /// Time between samples, s.
    pub interval_s: f64,
    /// What receives each sample.
    pub on_sample: &'a mut dyn FnMut(&TwoPlaneSample),
}

impl Sampling<'_> {
    /// The interval's check: positive and finite, and at most `limits::MAX_SAMPLES` samples
    /// up to the run's end `t_end_s`.
    pub(crate) fn check(&self, t_end_s: f64) -> Result<(), SimError> {
        crate::params::positive("sample interval (s)", self.interval_s)?;
        crate::params::non_negative("first sample time (s)", self.start_s)?;
        let d = self.interval_s;
        let span = (t_end_s - self.start_s).max(0.0);
        limits::check_derived(
            "time sampled / sample interval (samples)",
            || format!("{span} s / {d} s"),
            span / d,
            0.0,
            limits::MAX_SAMPLES,
            "sample less often or shorten the run",
        )?;
        Ok(())
    }
}

/// The energy book of a run: `ΔE = W_F − W_C − W_impact − W_slide − W_roll` with
/// `E = ½M|u̇|² + ½uᵀKu + ½m_d|ḃ|² + ½Iω² − m_d g·b`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TwoPlaneBook {
    /// Work of the harmonic force.
    pub forcing_work_j: f64,
    /// Viscous loss of the bar.
    pub viscous_loss_j: f64,
    /// Kinetic energy (translation and spin) lost in impacts and summed bounce sequences.
    pub impact_loss_j: f64,
    /// Loss of sliding friction in resting contact.
    pub sliding_loss_j: f64,
    /// Loss of rolling resistance.
    pub rolling_loss_j: f64,
    /// `E(end) − E(start)`.
    pub energy_change_j: f64,
}

impl TwoPlaneBook {
    /// What the book leaves unexplained (zero up to the integration error).
    pub fn residual_j(&self) -> f64 {
        self.forcing_work_j
            - self.viscous_loss_j
            - self.impact_loss_j
            - self.sliding_loss_j
            - self.rolling_loss_j
            - self.energy_change_j
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
    /// Fraction of the window the ball rests on each wall ([`HoleWall`] order), by how it
    /// moves along it ([`WallMotion`] order). A corner counts for both walls.
    pub contact_fraction: [[f64; 3]; 4],
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

impl TwoPlaneSummary {
    /// Fraction of the window the ball rests on `wall`, however it moves along it.
    pub fn rest_fraction(&self, wall: HoleWall) -> f64 {
        self.contact_fraction[wall as usize].iter().sum()
    }
}

/// Check a start: finite, the ball inside its box.
pub(crate) fn check_start(sys: &TwoPlaneSystem, start: &TwoPlaneStart) -> Result<(), ParamError> {
    let clr = [sys.hole.half_axial_gap_m(), sys.radial_clearance_m()];
    for (axis, field) in [(0, "start.w_hole_m[0]"), (1, "start.w_hole_m[1]")] {
        crate::params::in_range(
            field,
            start.w_hole_m[axis],
            -clr[axis],
            clr[axis],
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
    Ok(())
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

/// Events allowed per grid step on average before a run is stopped.
const EVENTS_PER_STEP: f64 = 4.0;

// State layout: u (0, 1), u̇ (2, 3), b (4, 5), ḃ (6, 7), ω (8), then the integrals: forcing
// work (9), viscous loss (10), sliding loss (11), rolling loss (12), and over the window
// ∫(u·e_F)² (13), ∫u_x² (14), ∫u_y² (15).
const NY: usize = 16;
const OM: usize = 8;
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

/// `ẑ × n`.
fn tangent(n: [f64; 2]) -> [f64; 2] {
    [-n[1], n[0]]
}

fn sgn(x: f64) -> i8 {
    if x > 0.0 {
        1
    } else if x < 0.0 {
        -1
    } else {
        0
    }
}

/// How a resting ball moves along its wall, with the signs the law needs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Tan {
    /// Sliding with slip sign `s` (0 on a frictionless wall: no friction force).
    Slide(i8),
    /// Rolling, with the sign of `ω` the rolling resistance opposes (0: none).
    Roll(i8),
    /// Held by rolling resistance.
    Stuck,
}

impl Tan {
    fn motion(self) -> WallMotion {
        match self {
            Tan::Slide(_) => WallMotion::Sliding,
            Tan::Roll(_) => WallMotion::Rolling,
            Tan::Stuck => WallMotion::Stuck,
        }
    }
}

/// The ball's mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    Flight,
    /// Resting on the wall of `axis` at `sign`.
    Wall {
        axis: usize,
        sign: i8,
        tan: Tan,
    },
    /// In a corner: on the walls at `signs[0]` along the hole and `signs[1]` across it;
    /// `tan` is `Slide(sgn ω)` (spinning) or `Stuck`.
    Corner {
        signs: [i8; 2],
        tan: Tan,
    },
}

impl Mode {
    /// The sign of the wall the ball rests on along `axis` (0: none).
    fn rest(self, axis: usize) -> i8 {
        match self {
            Mode::Flight => 0,
            Mode::Wall { axis: a, sign, .. } => {
                if a == axis {
                    sign
                } else {
                    0
                }
            }
            Mode::Corner { signs, .. } => signs[axis],
        }
    }
}

/// Accelerations and contact forces of a mode at one state.
#[derive(Debug, Clone, Copy, Default)]
struct Forces {
    ddu: [f64; 2],
    ddb: [f64; 2],
    dom: f64,
    /// Normal force per axis (0 off the walls).
    normal: [f64; 2],
    /// Friction force on the ball along the wall's tangent (single wall).
    fric: f64,
    /// Rolling-resistance torque.
    torque: f64,
    slide_power: f64,
    roll_power: f64,
}

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
    r: f64,
    inertia: f64,
    mu_s: f64,
    mu_k: f64,
    eta: f64,
    w_nn: f64,
    w_tt: f64,
    /// Guard tolerances: depth beyond a wall, force, speed, spin.
    tol_x: f64,
    tol_f: f64,
    tol_v: f64,
    tol_w: f64,
}

impl Model {
    fn new(sys: &TwoPlaneSystem) -> Model {
        let bar = sys.bar.lumped().copied().unwrap_or(PlanarBar {
            mass_kg: 1.0,
            stiffness_n_per_m: [1.0; 2],
            damping_ratio: [0.0; 2],
            principal_axis_deg: 0.0,
        });
        let (m, md) = (bar.mass_kg, sys.ball.mass_kg);
        let (k, c) = bar.matrices();
        let clr = [sys.hole.half_axial_gap_m(), sys.radial_clearance_m()];
        let g_abs = sys.gravity.m_s2;
        let gd = direction(sys.gravity.angle_deg);
        let om = sys.omega_rad_s();
        let acc = (g_abs + sys.forcing.amplitude_n.abs() / m).max(1e-300);
        let v_scale = acc / om.max(bar.omega1_rad_s());
        Model {
            m,
            md,
            red: m * md / (m + md),
            k,
            c,
            f0: sys.forcing.amplitude_n,
            om,
            e_f: direction(sys.forcing.angle_deg),
            g: [g_abs * gd[0], g_abs * gd[1]],
            axes: [
                direction(sys.hole.angle_deg),
                direction(sys.hole.angle_deg + 90.0),
            ],
            clr,
            e: sys.ball.restitution,
            r: sys.ball.radius_m,
            inertia: sys.ball.inertia_kg_m2(),
            mu_s: sys.ball.friction_static,
            mu_k: sys.ball.friction_kinetic,
            eta: sys.ball.rolling_friction_m,
            w_nn: inverse_mass_normal_per_kg(md, m),
            w_tt: inverse_mass_tangential_per_kg(md, m),
            tol_x: 1e-12 * clr[0].min(clr[1]).max(1e-300),
            tol_f: 1e-13 * md * acc,
            tol_v: 1e-12 * v_scale,
            tol_w: 1e-12 * v_scale / sys.ball.radius_m,
        }
    }

    fn frictional(&self) -> bool {
        self.mu_s > 0.0
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

    /// The outward normal of the wall of `axis` at sign `s`.
    fn normal(&self, axis: usize, s: f64) -> [f64; 2] {
        [s * self.axes[axis][0], s * self.axes[axis][1]]
    }

    /// Normal force on a ball resting on the wall with outward normal `n`.
    fn normal_force(&self, f: [f64; 2], n: [f64; 2]) -> f64 {
        self.red * (dot(self.g, n) - dot(f, n) / self.m)
    }

    /// Relative velocity `ḃ − u̇`.
    fn rel_v(y: &Y) -> [f64; 2] {
        [y[6] - y[2], y[7] - y[3]]
    }

    /// The slip of the contact point on the wall with outward normal `n`.
    fn slip(&self, y: &Y, n: [f64; 2]) -> f64 {
        dot(Self::rel_v(y), tangent(n)) + self.r * y[OM]
    }

    /// Friction force and rolling-resistance torque on a ball resting on the wall `n` with
    /// normal force `nf`, moving as `tan`.
    fn wall_friction(&self, f: [f64; 2], n: [f64; 2], nf: f64, tan: Tan) -> (f64, f64) {
        let tv = tangent(n);
        let drive = dot(self.g, tv) - dot(f, tv) / self.m;
        match tan {
            Tan::Slide(s) => (-self.mu_k * nf * f64::from(s), 0.0),
            Tan::Roll(rr) => {
                let tq = -self.eta * nf * f64::from(rr);
                (-(drive + self.r * tq / self.inertia) / self.w_tt, tq)
            }
            Tan::Stuck => {
                let fr = -drive / self.w_nn;
                (fr, -self.r * fr)
            }
        }
    }

    fn forces(&self, t: f64, y: &Y, mode: Mode) -> Forces {
        let f = self.bar_force(t, y);
        match mode {
            Mode::Flight => Forces {
                ddu: [f[0] / self.m, f[1] / self.m],
                ddb: self.g,
                ..Forces::default()
            },
            Mode::Wall { axis, sign, tan } => {
                let n = self.normal(axis, f64::from(sign));
                let tv = tangent(n);
                let nf = self.normal_force(f, n);
                let (fr, tq) = self.wall_friction(f, n, nf, tan);
                let mut out = Forces {
                    ddu: [
                        (f[0] + nf * n[0] - fr * tv[0]) / self.m,
                        (f[1] + nf * n[1] - fr * tv[1]) / self.m,
                    ],
                    ddb: [
                        self.g[0] + (-nf * n[0] + fr * tv[0]) / self.md,
                        self.g[1] + (-nf * n[1] + fr * tv[1]) / self.md,
                    ],
                    dom: (self.r * fr + tq) / self.inertia,
                    fric: fr,
                    torque: tq,
                    ..Forces::default()
                };
                out.normal[axis] = nf;
                match tan {
                    Tan::Slide(_) => out.slide_power = -fr * self.slip(y, n),
                    Tan::Roll(_) => out.roll_power = -tq * y[OM],
                    Tan::Stuck => {}
                }
                out
            }
            Mode::Corner { signs, tan } => {
                let mt = self.m + self.md;
                let ddu = [
                    (f[0] + self.md * self.g[0]) / mt,
                    (f[1] + self.md * self.g[1]) / mt,
                ];
                let q = [
                    self.md * (self.g[0] - ddu[0]),
                    self.md * (self.g[1] - ddu[1]),
                ];
                let n0 = self.normal(0, f64::from(signs[0]));
                let n1 = self.normal(1, f64::from(signs[1]));
                let s = match tan {
                    Tan::Slide(s) => f64::from(s),
                    _ => 0.0,
                };
                // N0 − F1 (t1·n0) = q·n0 and N1 − F0 (t0·n1) = q·n1, with F_i = −μ_k N_i s.
                let a = self.mu_k * s * dot(tangent(n1), n0);
                let b = self.mu_k * s * dot(tangent(n0), n1);
                let (q0, q1) = (dot(q, n0), dot(q, n1));
                let det = 1.0 - a * b;
                let nf0 = (q0 - a * q1) / det;
                let nf1 = (q1 - b * q0) / det;
                let fr = -self.mu_k * s * (nf0 + nf1);
                Forces {
                    ddu,
                    ddb: ddu,
                    dom: self.r * fr / self.inertia,
                    normal: [nf0, nf1],
                    fric: fr,
                    slide_power: -fr * self.r * y[OM],
                    ..Forces::default()
                }
            }
        }
    }

    fn deriv(&self, t: f64, y: &Y, mode: Mode, win: f64) -> Y {
        let fo = self.forces(t, y, mode);
        let du = [y[2], y[3]];
        let fs = self.f0 * (self.om * t).sin();
        let uf = y[0] * self.e_f[0] + y[1] * self.e_f[1];
        [
            y[2],
            y[3],
            fo.ddu[0],
            fo.ddu[1],
            y[6],
            y[7],
            fo.ddb[0],
            fo.ddb[1],
            fo.dom,
            fs * dot(self.e_f, du),
            dot(du, mat(&self.c, du)),
            fo.slide_power,
            fo.roll_power,
            win * uf * uf,
            win * y[0] * y[0],
            win * y[1] * y[1],
        ]
    }

    fn step(&self, t: f64, y: &Y, h: f64, mode: Mode, win: f64) -> Y {
        let add = |a: &Y, k: &Y, s: f64| {
            let mut o = *a;
            for i in 0..NY {
                o[i] += s * k[i];
            }
            o
        };
        let k1 = self.deriv(t, y, mode, win);
        let k2 = self.deriv(t + 0.5 * h, &add(y, &k1, 0.5 * h), mode, win);
        let k3 = self.deriv(t + 0.5 * h, &add(y, &k2, 0.5 * h), mode, win);
        let k4 = self.deriv(t + h, &add(y, &k3, h), mode, win);
        let mut o = *y;
        for i in 0..NY {
            o[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
        o
    }

    /// The state `y` in the form a start takes (the ball in the hole's frame).
    fn state_of(&self, y: &Y) -> TwoPlaneStart {
        let [a, n] = self.axes;
        let w = [y[4] - y[0], y[5] - y[1]];
        let dw = Model::rel_v(y);
        TwoPlaneStart {
            u_m: [y[0], y[1]],
            du_m_s: [y[2], y[3]],
            w_hole_m: [dot(w, a), dot(w, n)],
            dw_hole_m_s: [dot(dw, a), dot(dw, n)],
            spin_rad_s: y[OM],
        }
    }

    /// The ball relative to the cavity's centre along `axis`.
    fn w(&self, y: &Y, axis: usize) -> f64 {
        dot([y[4] - y[0], y[5] - y[1]], self.axes[axis])
    }

    /// The guards, positive once crossed; `−∞` where none applies. 0–3: the depth beyond a wall
    /// the ball flies towards ([`HoleWall`] order); 4, 5: the tension on the wall it rests on
    /// along each axis; 6, 7: the limits of its motion along the wall.
    fn guards(&self, t: f64, y: &Y, mode: Mode) -> [f64; 8] {
        let mut out = [f64::NEG_INFINITY; 8];
        let fo = self.forces(t, y, mode);
        for axis in 0..2 {
            if mode.rest(axis) == 0 {
                let w = self.w(y, axis);
                out[2 * axis] = w - self.clr[axis] - self.tol_x;
                out[2 * axis + 1] = -w - self.clr[axis] - self.tol_x;
            } else {
                out[4 + axis] = -fo.normal[axis] - self.tol_f;
            }
        }
        if !self.frictional() {
            return out;
        }
        match mode {
            Mode::Flight => {}
            Mode::Wall { axis, sign, tan } => {
                let nf = fo.normal[axis];
                match tan {
                    Tan::Slide(s) => {
                        let n = self.normal(axis, f64::from(sign));
                        out[6] = -f64::from(s) * self.slip(y, n) - self.tol_v;
                    }
                    Tan::Roll(rr) => {
                        out[6] = fo.fric.abs() - self.mu_s * nf - self.tol_f;
                        if rr != 0 {
                            out[7] = -f64::from(rr) * y[OM] - self.tol_w;
                        }
                    }
                    Tan::Stuck => {
                        out[6] = fo.fric.abs() - self.mu_s * nf - self.tol_f;
                        out[7] = fo.torque.abs() - self.eta * nf - self.r * self.tol_f;
                    }
                }
            }
            Mode::Corner { tan, .. } => {
                if let Tan::Slide(s) = tan {
                    if s != 0 {
                        out[6] = -f64::from(s) * y[OM] - self.tol_w;
                    }
                }
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

    /// Remove the ball's velocity relative to the bar along `axis`.
    fn hold(&self, y: &mut Y, axis: usize) {
        let a = self.axes[axis];
        let dw = dot(Self::rel_v(y), a);
        y[6] -= dw * a[0];
        y[7] -= dw * a[1];
    }

    /// Keep the constraints of `mode` exact: position and normal velocity on the walls, no
    /// slip while rolling, no slip and no spin while stuck.
    fn project(&self, y: &mut Y, mode: Mode) {
        for axis in 0..2 {
            let s = mode.rest(axis);
            if s != 0 {
                self.snap(y, axis, f64::from(s));
                self.hold(y, axis);
            }
        }
        match mode {
            Mode::Wall { axis, sign, tan } => {
                let n = self.normal(axis, f64::from(sign));
                match tan {
                    Tan::Roll(_) => y[OM] -= self.slip(y, n) / self.r,
                    Tan::Stuck => {
                        self.hold(y, 1 - axis);
                        y[OM] = 0.0;
                    }
                    Tan::Slide(_) => {}
                }
            }
            Mode::Corner {
                tan: Tan::Stuck, ..
            } => y[OM] = 0.0,
            _ => {}
        }
    }

    fn kinetic(&self, y: &Y) -> f64 {
        0.5 * self.m * (y[2] * y[2] + y[3] * y[3])
            + 0.5 * self.md * (y[6] * y[6] + y[7] * y[7])
            + 0.5 * self.inertia * y[OM] * y[OM]
    }

    fn energy(&self, y: &Y) -> f64 {
        let u = [y[0], y[1]];
        self.kinetic(y) + 0.5 * dot(u, mat(&self.k, u)) - self.md * dot(self.g, [y[4], y[5]])
    }

    /// Impulses `p_n` along `−n` and `p_t` along `t = ẑ × n` on the ball at the contact point
    /// of wall `n`; the opposite on the bar.
    fn impulse(&self, y: &mut Y, n: [f64; 2], p_n: f64, p_t: f64) {
        let tv = tangent(n);
        for i in 0..2 {
            let j = -p_n * n[i] + p_t * tv[i];
            y[6 + i] += j / self.md;
            y[2 + i] -= j / self.m;
        }
        y[OM] += self.r * p_t / self.inertia;
    }

    /// The impact law at the wall of `axis`, `s`; returns the approach speed.
    fn impact(&self, y: &mut Y, axis: usize, s: f64) -> f64 {
        let n = self.normal(axis, s);
        let approach = dot(Self::rel_v(y), n).max(0.0);
        let p = wall_impact(
            approach,
            self.slip(y, n),
            self.w_nn,
            self.w_tt,
            self.e,
            self.mu_k,
        );
        self.impulse(y, n, p.normal_n_s, p.tangential_n_s);
        approach
    }

    /// How a ball resting on wall `n` moves along it from this state on.
    fn settle_wall(&self, t: f64, y: &Y, axis: usize, sign: i8) -> Tan {
        if !self.frictional() {
            return Tan::Slide(0);
        }
        let n = self.normal(axis, f64::from(sign));
        let sigma = self.slip(y, n);
        if sigma.abs() > 1e3 * self.tol_v {
            return Tan::Slide(sgn(sigma));
        }
        let f = self.bar_force(t, y);
        let nf = self.normal_force(f, n).max(0.0);
        let (fr, tq) = self.wall_friction(f, n, nf, Tan::Stuck);
        if y[OM].abs() <= 1e3 * self.tol_w
            && self.eta > 0.0
            && fr.abs() <= self.mu_s * nf
            && tq.abs() <= self.eta * nf
        {
            return Tan::Stuck;
        }
        // Rolling: the resistance opposes the spin, or the spin the drive would start.
        let rr = if y[OM].abs() > 1e3 * self.tol_w {
            sgn(y[OM])
        } else {
            let (fr0, _) = self.wall_friction(f, n, nf, Tan::Roll(0));
            sgn(fr0)
        };
        let (fr, _) = self.wall_friction(f, n, nf, Tan::Roll(rr));
        if fr.abs() <= self.mu_s * nf {
            Tan::Roll(if self.eta > 0.0 { rr } else { 0 })
        } else {
            // Kinetic friction opposes the slip that starts, which is against the friction
            // rolling would need.
            Tan::Slide(-sgn(fr))
        }
    }

    /// The mode for a ball resting on the walls `signs` (0: none along that axis).
    fn settle(&self, t: f64, y: &Y, signs: [i8; 2]) -> Mode {
        match signs {
            [0, 0] => Mode::Flight,
            [s, 0] => Mode::Wall {
                axis: 0,
                sign: s,
                tan: self.settle_wall(t, y, 0, s),
            },
            [0, s] => Mode::Wall {
                axis: 1,
                sign: s,
                tan: self.settle_wall(t, y, 1, s),
            },
            _ => Mode::Corner {
                signs,
                tan: if self.frictional() && y[OM].abs() > 1e3 * self.tol_w {
                    Tan::Slide(sgn(y[OM]))
                } else if self.frictional() {
                    Tan::Stuck
                } else {
                    Tan::Slide(0)
                },
            },
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
        self.run_from(sys, start, 0.0, settings, on_event, None)
    }

    /// [`TwoPlaneRk4::run`] from the state `start` at time `t0_s` (the forcing's phase is `Ωt0`)
    /// over `settings.duration_s`, sampling the state as `sampling` asks; the RMS window is the
    /// last fraction of that span.
    pub fn run_from(
        &self,
        sys: &TwoPlaneSystem,
        start: &TwoPlaneStart,
        t0_s: f64,
        settings: &RunSettings,
        on_event: &mut dyn FnMut(&TwoPlaneEvent),
        mut sampling: Option<Sampling>,
    ) -> Result<TwoPlaneSummary, SimError> {
        sys.validate()?;
        crate::params::non_negative("start time t0_s", t0_s)?;
        settings.validate()?;
        let h = self.dt_s;
        crate::params::positive("dt_s", h)?;
        if sys.bar.lumped().is_none() {
            return Err(SimError::Unsupported(
                "the two-plane reference solver runs the lumped bar only; a bar of modes runs on \
                 the exact solver (frictionless walls, measured modes bending along and across \
                 the hole)",
            ));
        }
        let omega_max = sys.bar.highest_omega_rad_s();
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
        limits::check_phase(sys.omega_rad_s().max(omega_max), t0_s + duration)?;
        let md = Model::new(sys);
        check_start(sys, start)?;
        if let Some(sm) = &sampling {
            sm.check(t0_s + duration)?;
        }
        // The next sample's index and time (∞ without sampling).
        let mut sample_k = 0u64;
        let plan = sampling
            .as_ref()
            .map_or((f64::INFINITY, 0.0), |sm| (sm.start_s, sm.interval_s));
        let sample_t = |k: u64| plan.0 + k as f64 * plan.1;
        let mut next_sample = sample_t(0);
        // Samples before the start are not the run's: the first at or after it.
        if next_sample < t0_s {
            sample_k = ((t0_s - plan.0) / plan.1).ceil() as u64;
            next_sample = sample_t(sample_k);
            if next_sample < t0_s {
                sample_k += 1;
                next_sample = sample_t(sample_k);
            }
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
        y[OM] = start.spin_rad_s;
        let e0 = md.energy(&y);

        // A ball at rest on a wall that presses it stays there.
        let f = md.bar_force(t0_s, &y);
        let signs = [0, 1].map(|axis| {
            let wa = start.w_hole_m[axis];
            let s = wa.signum();
            let on_wall = (wa.abs() - md.clr[axis]).abs() <= md.tol_x;
            let pressed = md.normal_force(f, md.normal(axis, s)) > 0.0;
            if on_wall && start.dw_hole_m_s[axis] == 0.0 && pressed {
                s as i8
            } else {
                0
            }
        });
        let mut mode = md.settle(t0_s, &y, signs);

        let t_end = t0_s + duration;
        let t_win = t0_s + duration * (1.0 - settings.rms_fraction);
        let max_events = (EVENTS_PER_STEP * steps).max(1e4) as u64;
        let mut t = t0_s;
        let mut grid = (t0_s / h).floor();
        if next_sample <= t0_s {
            if let Some(sm) = sampling.as_mut() {
                (sm.on_sample)(&TwoPlaneSample {
                    t_s: t0_s,
                    state: md.state_of(&y),
                });
            }
            sample_k += 1;
            next_sample = sample_t(sample_k);
        }
        let mut out = TwoPlaneSummary {
            rms_along_force_m: 0.0,
            rms_m: [0.0; 2],
            rms_total_m: 0.0,
            impacts: [0; 4],
            contact_fraction: [[0.0; 3]; 4],
            flight_fraction: 0.0,
            events: 0,
            max_penetration_m: f64::NEG_INFINITY,
            book: TwoPlaneBook::default(),
            end: *start,
        };
        let mut loss = 0.0;
        let mut contact_time = [[0.0; 3]; 4];
        let mut flight_time = 0.0;
        let mut emit = |out: &mut TwoPlaneSummary, t: f64, kind: TwoPlaneEventKind| {
            on_event(&TwoPlaneEvent { t_s: t, kind });
            out.events += 1;
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
        };

        while t < t_end {
            // The next grid point (the window's start and the end are grid points too).
            while grid * h <= t {
                grid += 1.0;
            }
            let mut t_next = (grid * h).min(t_end);
            if t < t_win && t_next > t_win {
                t_next = t_win;
            }
            // A step ends at each sample time; one past the end by rounding only is the end's.
            if next_sample <= t_end + 1e-9 * h {
                let ts = next_sample.min(t_end);
                if t < ts && t_next > ts {
                    t_next = ts;
                }
            }
            let win = if t >= t_win { 1.0 } else { 0.0 };
            let span = t_next - t;
            let y1 = md.step(t, &y, span, mode, win);
            let g1 = md.guards(t_next, &y1, mode);
            let (tau, y_new, hit) = if g1.iter().any(|&g| g > 0.0) {
                let g0 = md.guards(t, &y, mode);
                let mut best = (span, usize::MAX);
                for k in 0..8 {
                    if g1[k] > 0.0 {
                        let tk = if g0[k] >= 0.0 {
                            0.0
                        } else {
                            let guard =
                                |tau| md.guards(t + tau, &md.step(t, &y, tau, mode, win), mode)[k];
                            locate(guard, g0[k], span, g1[k])
                        };
                        if best.1 == usize::MAX || tk < best.0 {
                            best = (tk, k);
                        }
                    }
                }
                let yk = if best.0 > 0.0 {
                    md.step(t, &y, best.0, mode, win)
                } else {
                    y
                };
                (best.0, yk, Some(best.1))
            } else {
                (span, y1, None)
            };
            // Time per mode over the window.
            if win > 0.0 {
                match mode {
                    Mode::Flight => flight_time += tau,
                    Mode::Wall { axis, sign, tan } => {
                        contact_time[HoleWall::of(axis, f64::from(sign)) as usize]
                            [tan.motion() as usize] += tau;
                    }
                    Mode::Corner { signs, tan } => {
                        for axis in 0..2 {
                            contact_time[HoleWall::of(axis, f64::from(signs[axis])) as usize]
                                [tan.motion() as usize] += tau;
                        }
                    }
                }
            }
            t = if hit.is_some() { t + tau } else { t_next };
            y = y_new;
            md.project(&mut y, mode);
            if hit.is_none() && t >= next_sample.min(t_end) && next_sample <= t_end + 1e-9 * h {
                if let Some(sm) = sampling.as_mut() {
                    (sm.on_sample)(&TwoPlaneSample {
                        t_s: next_sample,
                        state: md.state_of(&y),
                    });
                }
                sample_k += 1;
                next_sample = sample_t(sample_k);
            }
            for axis in 0..2 {
                if mode.rest(axis) == 0 {
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
            let mut signs = [mode.rest(0), mode.rest(1)];
            if k >= 6 {
                // The motion along the wall changes.
                let new = md.settle(t, &y, signs);
                // A corner reports the hole's wall.
                let changed = match new {
                    Mode::Wall { axis, sign, tan } => Some((axis, sign, tan)),
                    Mode::Corner { signs, tan } => Some((1, signs[1], tan)),
                    Mode::Flight => None,
                };
                if let Some((axis, sign, tan)) = changed {
                    let wall = HoleWall::of(axis, f64::from(sign));
                    let motion = tan.motion();
                    emit(&mut out, t, TwoPlaneEventKind::Motion { wall, motion })?;
                }
                mode = new;
                md.project(&mut y, mode);
                continue;
            }
            if k >= 4 {
                let axis = k - 4;
                let wall = HoleWall::of(axis, f64::from(signs[axis]));
                signs[axis] = 0;
                mode = md.settle(t, &y, signs);
                emit(&mut out, t, TwoPlaneEventKind::LiftOff { wall })?;
                continue;
            }
            // An impact at wall `k`, then at any wall the ball rested on that its impulse
            // drives it into, until nothing approaches.
            let wall = HoleWall::ALL[k];
            let (axis, s) = (wall.axis(), wall.sign());
            md.snap(&mut y, axis, s);
            let ke = md.kinetic(&y);
            let approach = md.impact(&mut y, axis, s);
            let other = 1 - axis;
            if signs[other] != 0 {
                let n_o = md.normal(other, f64::from(signs[other]));
                let v_o = dot(Model::rel_v(&y), n_o);
                if v_o > md.tol_v {
                    md.impact(&mut y, other, f64::from(signs[other]));
                    // That impulse is normal to the first wall's normal: it does not drive the
                    // ball back into the first wall, but its friction may.
                    let n = md.normal(axis, s);
                    if dot(Model::rel_v(&y), n) > md.tol_v {
                        md.impact(&mut y, axis, s);
                    }
                }
                let v_o = dot(Model::rel_v(&y), n_o);
                if v_o < -md.tol_v {
                    let w_o = HoleWall::of(other, f64::from(signs[other]));
                    signs[other] = 0;
                    emit(&mut out, t, TwoPlaneEventKind::LiftOff { wall: w_o })?;
                } else {
                    md.hold(&mut y, other);
                }
            }
            let lost = ke - md.kinetic(&y);
            loss += lost;
            out.impacts[k] += 1;
            emit(
                &mut out,
                t,
                TwoPlaneEventKind::Impact {
                    wall,
                    approach_m_s: approach,
                    energy_loss_j: lost,
                },
            )?;
            // Sum the bounces to their end if the next one would be shorter than a step.
            let n = md.normal(axis, s);
            let press = md.normal_force(md.bar_force(t, &y), n) / md.red;
            let recede = -dot(Model::rel_v(&y), n);
            if press > 0.0 && 2.0 * recede < press * h {
                let ke = md.kinetic(&y);
                // The plastic limit: the common normal velocity, momentum conserved.
                md.impulse(&mut y, n, -recede / md.w_nn, 0.0);
                let lost = ke - md.kinetic(&y);
                loss += lost;
                signs[axis] = s as i8;
                emit(
                    &mut out,
                    t,
                    TwoPlaneEventKind::Rest {
                        wall,
                        energy_loss_j: lost,
                    },
                )?;
            }
            mode = md.settle(t, &y, signs);
            md.project(&mut y, mode);
        }

        let t_w = t_end - t_win;
        out.rms_along_force_m = (y[13] / t_w).sqrt();
        out.rms_m = [(y[14] / t_w).sqrt(), (y[15] / t_w).sqrt()];
        out.rms_total_m = ((y[14] + y[15]) / t_w).sqrt();
        out.flight_fraction = flight_time / t_w;
        out.contact_fraction = contact_time.map(|r| r.map(|v| v / t_w));
        out.book = TwoPlaneBook {
            forcing_work_j: y[9],
            viscous_loss_j: y[10],
            impact_loss_j: loss,
            sliding_loss_j: y[11],
            rolling_loss_j: y[12],
            energy_change_j: md.energy(&y) - e0,
        };
        out.end = md.state_of(&y);
        Ok(out)
    }
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
