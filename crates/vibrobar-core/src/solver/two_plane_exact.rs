//! The exact solver of the bar that bends in two planes, where its planes decouple.
//!
//! On frictionless walls a wall's impulse and its resting force act along the wall's normal
//! only, so the ball's motion along the hole and across it are two separate impact dampers:
//! along the hole the plugs at `±l_g`, across it the hole's wall at `±c_r`. When the bar's
//! principal axes lie along and across the hole (any pair of axes of a round bar does), its two
//! planes there are separate oscillators too, each driven by the force's component and carrying
//! gravity's component on the ball as a body force. The two-plane run is then exactly two
//! one-plane runs of [`super::Exact`], the one solver stack, and this module runs them side by
//! side and puts them together:
//!
//! * each plane's `∫u²` over the window, its books and its events come from its own run, exact;
//! * what needs both planes at once (the RMS along the force, along `x` and `y`, and the time
//!   the ball touches no wall) is integrated over the pieces both runs share: the plane along the
//!   hole runs on a second thread and streams its motion over the window, split at its events,
//!   and the plane across the hole integrates the product of the two displacements over the
//!   common pieces. On the lumped bar each piece is a segment's closed form (an exponential sum)
//!   and the product integral is closed too, one per pair of overlapping segments. On a bar of
//!   modes the pieces are Chebyshev interpolants no longer than `1/ω` (ω the highest frequency
//!   of the bar or the force), integrated by Gauss–Legendre quadrature; both rules are exact for
//!   polynomials far beyond the pieces' smoothness, so the cross term carries ~1e-12 relative
//!   error. Memory stays bounded by the stream's buffer;
//! * the events of the two planes are reported in the order of time.
//!
//! Where the planes do not decouple (friction on the walls, which couples them through the
//! normal force; principal axes at a slant to the hole; no radial clearance), [`decoupled`] says
//! why, and the reference solver [`super::two_plane_rk4`] is the one that runs.

use std::collections::VecDeque;
use std::sync::mpsc::{channel, sync_channel, Receiver, Sender, SyncSender};

use super::exact::cutting::GL8;
use super::exact::lumped::expsum::{integral_product_shifted, ExpSum};
use super::two_plane_rk4::{
    HoleWall, Sampling, TwoPlaneBook, TwoPlaneEvent, TwoPlaneEventKind, TwoPlaneSample,
    TwoPlaneStart, TwoPlaneSummary, WallMotion,
};
use super::{Event, EventKind, Exact, Mode, Observer, RunSummary, Segment, Solver, Wall};
use crate::error::SimError;
use crate::params::two_plane::{direction, TwoPlaneBar, TwoPlaneSystem};
use crate::params::{
    Bar, BarModel, Contact, Damper, Forcing, Frequency, FrictionModel, RunSettings, State, System,
};

/// Chebyshev–Lobatto nodes per streamed piece.
const NODES: usize = 12;

/// Messages per batch of the stream: the reading end is woken once per batch.
const BATCH: usize = 256;

/// Batches the stream holds at most before the plane along the hole waits.
const STREAM_BATCHES: usize = 16;

/// Why the planes of `sys` do not decouple, or `Ok` when they do.
pub fn decoupled(sys: &TwoPlaneSystem) -> Result<(), &'static str> {
    if sys.ball.friction_static != 0.0 || sys.ball.friction_kinetic != 0.0 {
        return Err(
            "the exact two-plane solver needs frictionless walls: friction couples the \
                    planes through the normal force",
        );
    }
    if sys.radial_clearance_m() <= 0.0 {
        return Err(
            "the exact two-plane solver needs a radial clearance: this hole leaves the \
                    ball none",
        );
    }
    principal_index(sys, 0).ok_or(
        "the exact two-plane solver needs the bar's principal axes (or its measured modes' \
         bending directions) along and across the hole: at a slant they couple the planes",
    )?;
    Ok(())
}

/// The index of the bar's principal axis along hole axis `axis` (0 along the hole, 1 across
/// it); `None` when no principal axis lies along it. A round bar's is 0 for both.
fn principal_index(sys: &TwoPlaneSystem, axis: usize) -> Option<usize> {
    let principal_deg = match &sys.bar {
        TwoPlaneBar::Round(_) => return Some(0),
        TwoPlaneBar::Lumped(bar) => {
            // Round: the same stiffness and damping on both axes, exactly.
            let round = bar.stiffness_n_per_m[0] - bar.stiffness_n_per_m[1] == 0.0
                && bar.damping_ratio[0] - bar.damping_ratio[1] == 0.0;
            if round {
                return Some(0);
            }
            bar.principal_axis_deg
        }
        TwoPlaneBar::Measured(p) => {
            if p.modes[0] == p.modes[1] {
                return Some(0);
            }
            p.axis_deg
        }
    };
    let rel = (sys.hole.angle_deg + 90.0 * axis as f64 - principal_deg).to_radians();
    let tol = 1e-12;
    if rel.sin().abs() <= tol {
        Some(0)
    } else if rel.cos().abs() <= tol {
        Some(1)
    } else {
        None
    }
}

/// The hole's axes: along it (`a`) and across it (`n = ẑ × a`).
pub fn hole_axes(sys: &TwoPlaneSystem) -> [[f64; 2]; 2] {
    [
        direction(sys.hole.angle_deg),
        direction(sys.hole.angle_deg + 90.0),
    ]
}

fn dot(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

/// The one-plane system of hole axis `axis` (0 along the hole, 1 across it) of a decoupled
/// two-plane system: the bar's principal stiffness and damping along it, the force's component,
/// the clearance (`2l_g` or `2c_r`) as the gap, gravity's component as a body force on the
/// ball, frictionless walls.
pub fn plane_system(sys: &TwoPlaneSystem, axis: usize) -> Result<System, SimError> {
    decoupled(sys).map_err(SimError::Unsupported)?;
    let j = principal_index(sys, axis).unwrap_or(0);
    let e = hole_axes(sys)[axis];
    let g = sys.gravity.m_s2;
    let g_along = g * dot(direction(sys.gravity.angle_deg), e);
    let gap_m = if axis == 0 {
        sys.hole.axial_gap_m
    } else {
        2.0 * sys.radial_clearance_m()
    };
    Ok(System {
        bar: match &sys.bar {
            TwoPlaneBar::Lumped(b) => BarModel::Lumped(Bar {
                mass_kg: b.mass_kg,
                stiffness_n_per_m: b.stiffness_n_per_m[j],
                damping_ratio: b.damping_ratio[j],
            }),
            TwoPlaneBar::Round(m) => BarModel::Modal(*m),
            TwoPlaneBar::Measured(p) => BarModel::Modal(p.modes[j]),
        },
        damper: Some(Damper {
            ball_mass_kg: sys.ball.mass_kg,
            ball_radius_m: sys.ball.radius_m,
            restitution: sys.ball.restitution,
            gap_m,
            rolling_friction_m: 0.0,
            friction: FrictionModel::None,
            friction_force_n: None,
            contact: Contact::default(),
            gravity_along_gap_m_s2: if g_along.abs() <= 1e-12 * g {
                0.0
            } else {
                g_along
            },
        }),
        forcing: Forcing {
            amplitude_n: sys.forcing.amplitude_n * dot(direction(sys.forcing.angle_deg), e),
            frequency: Frequency::RadPerS(sys.omega_rad_s()),
            static_force_n: 0.0,
        },
        // Read by friction only, which these planes do not have.
        gravity_m_s2: if g > 0.0 {
            g
        } else {
            crate::params::STANDARD_GRAVITY_M_S2
        },
    })
}

/// The one-plane start of hole axis `axis` (0 along the hole, 1 across it) at `t0_s`: the bar's
/// displacement and velocity along the axis, the ball at the bar's plus its place relative to
/// the cavity.
pub fn plane_start(sys: &TwoPlaneSystem, start: &TwoPlaneStart, axis: usize, t0_s: f64) -> State {
    let e = hole_axes(sys)[axis];
    let (u, du) = (dot(start.u_m, e), dot(start.du_m_s, e));
    State {
        t_s: t0_s,
        u_m: u,
        du_m_s: du,
        v_m: u + start.w_hole_m[axis],
        dv_m_s: du + start.dw_hole_m_s[axis],
        cavity: None,
    }
}

/// A piece of the plane along the hole inside the window: its displacement over `[t0, t1]`,
/// and whether the ball rests on a plug.
#[derive(Debug, Clone, Copy)]
struct Piece {
    t0: f64,
    t1: f64,
    shape: Shape,
    contact: bool,
}

/// How a piece holds its displacement.
#[derive(Debug, Clone, Copy)]
enum Shape {
    /// The segment's closed form, `u(t) = x(t − origin)` (a whole segment's share of the window).
    Sum { x: ExpSum, origin: f64 },
    /// Its values at the Chebyshev–Lobatto nodes of `[t0, t1]`.
    Nodes([f64; NODES]),
}

/// The Chebyshev–Lobatto nodes `cos(πj/(n−1))` on `[−1, 1]` and their barycentric weights
/// (`(−1)^j`, halved at the ends).
fn lobatto() -> &'static ([f64; NODES], [f64; NODES]) {
    static TABLE: std::sync::OnceLock<([f64; NODES], [f64; NODES])> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        let mut x = [0.0; NODES];
        let mut w = [0.0; NODES];
        for j in 0..NODES {
            x[j] = (std::f64::consts::PI * j as f64 / (NODES - 1) as f64).cos();
            w[j] = if j % 2 == 0 { 1.0 } else { -1.0 };
            if j == 0 || j == NODES - 1 {
                w[j] *= 0.5;
            }
        }
        (x, w)
    })
}

impl Piece {
    /// Node `j` in `[t0, t1]` (node 0 at `t1`).
    fn node(t0: f64, t1: f64, j: usize) -> f64 {
        0.5 * (t0 + t1) + 0.5 * (t1 - t0) * lobatto().0[j]
    }

    /// The displacement at `t` (for nodes, the barycentric formula).
    fn at(&self, t: f64) -> f64 {
        let u = match &self.shape {
            Shape::Sum { x, origin } => return x.value(t - origin),
            Shape::Nodes(u) => u,
        };
        let (x, w) = lobatto();
        let tau = (2.0 * t - self.t0 - self.t1) / (self.t1 - self.t0);
        let (mut num, mut den) = (0.0, 0.0);
        for j in 0..NODES {
            let d = tau - x[j];
            if d == 0.0 {
                return u[j];
            }
            let q = w[j] / d;
            num += q * u[j];
            den += q;
        }
        num / den
    }
}

/// What the plane along the hole streams.
#[derive(Debug, Clone, Copy)]
enum Msg {
    Piece(Piece),
    Event(TwoPlaneEvent),
    /// The plane's state at sample `k` of the sampling grid.
    Sample(u64, PlaneState),
}

/// One plane's state at a sample: the bar's displacement and velocity along the plane's axis,
/// the ball's relative to the cavity.
#[derive(Debug, Clone, Copy)]
struct PlaneState {
    u: f64,
    du: f64,
    w: f64,
    dw: f64,
}

impl PlaneState {
    fn of(s: &State) -> PlaneState {
        PlaneState {
            u: s.u_m,
            du: s.du_m_s,
            w: s.v_m - s.u_cavity_m(),
            dw: s.dv_m_s - s.du_cavity_m_s(),
        }
    }
}

/// The sampling grid `t_k = start + k·interval` as one plane walks it (the convention of the one-plane
/// history: a sample at an event's time belongs to the segment that ends there).
#[derive(Debug, Clone, Copy)]
struct Grid {
    start_s: f64,
    interval_s: f64,
    next_k: u64,
}

impl Grid {
    /// The time of sample `k`.
    fn time(&self, k: u64) -> f64 {
        self.start_s + k as f64 * self.interval_s
    }

    /// The samples of `seg` not yet taken, with their indices. A grid time past the segment's
    /// end by rounding only (`k·interval` against a sum of steps; 1e-9 of the interval) is the
    /// end's sample, so that a run whose duration is a multiple of the interval ends on one.
    fn take(&mut self, seg: &dyn Segment, mut f: impl FnMut(u64, PlaneState)) {
        let (t0, t1) = (seg.t_start_s(), seg.t_end_s());
        loop {
            let t = self.time(self.next_k);
            if t > t1 + 1e-9 * self.interval_s {
                return;
            }
            if t >= t0 {
                f(self.next_k, PlaneState::of(&seg.state_at(t.min(t1))));
            }
            self.next_k += 1;
        }
    }
}

/// The writing end of the stream. Messages go in batches, so that the reading end is woken once
/// per batch rather than per piece (a wake-up costs more than a piece), and the emptied batches
/// come back to be refilled: the stream allocates only its first few, and holds at most
/// `STREAM_BATCHES + 2` of them.
struct Stream {
    tx: SyncSender<Vec<Msg>>,
    back: Receiver<Vec<Msg>>,
    batch: Vec<Msg>,
}

impl Stream {
    /// Queue `m`; `false` once the reading end is gone.
    fn push(&mut self, m: Msg) -> bool {
        self.batch.push(m);
        self.batch.len() < BATCH || self.flush()
    }

    /// Send what is queued; `false` once the reading end is gone.
    fn flush(&mut self) -> bool {
        if self.batch.is_empty() {
            return true;
        }
        let next = self
            .back
            .try_recv()
            .unwrap_or_else(|_| Vec::with_capacity(BATCH));
        let full = std::mem::replace(&mut self.batch, next);
        self.tx.send(full).is_ok()
    }
}

/// What one plane's run adds up.
#[derive(Debug, Clone, Copy, Default)]
struct PlaneTotals {
    /// `∫u²` over the window.
    u2: f64,
    forcing_work_j: f64,
    viscous_loss_j: f64,
    impact_loss_j: f64,
    /// Impacts on the `+` and `−` walls.
    impacts: [u64; 2],
    /// Window time resting on the `+` and `−` walls.
    rest_s: [f64; 2],
    /// Mechanical energy (with the body force's potential) at the start and the end.
    energy_start_j: Option<f64>,
    energy_end_j: f64,
}

/// The observer of one plane: its totals, and its share of the stream.
struct PlaneObserver<'a> {
    axis: usize,
    /// The RMS window; its end is the run's.
    window: (f64, f64),
    /// `m_d·g` along the plane's slot (the body force's potential is `−m_d g v`).
    weight_n: f64,
    totals: PlaneTotals,
    /// The plane along the hole: where it streams to (`None` once the other end is gone).
    tx: Option<Stream>,
    /// The largest piece length.
    h_max_s: f64,
    /// Whether to use the segments' closed forms where they have them (the nodes otherwise).
    closed_form: bool,
    /// The sampling grid, when the run is sampled.
    grid: Option<Grid>,
    /// The plane across the hole: the stream it reads and what it does with it.
    rx: Option<Cross<'a>>,
}

/// The plane across the hole's reading of the stream.
struct Cross<'a> {
    rx: Receiver<Vec<Msg>>,
    /// Where emptied batches go back to.
    back: Sender<Vec<Msg>>,
    /// The batch being read, and the position in it.
    batch: Vec<Msg>,
    pos: usize,
    /// The piece the stream reached (straddling the last time asked for).
    cur: Option<Piece>,
    /// Events of the plane along the hole not yet reported.
    pending: VecDeque<TwoPlaneEvent>,
    /// Time up to which the stream has been read.
    stream_t: f64,
    /// `∫u_a u_n` over the window.
    cross: f64,
    /// Window time the ball touches no wall.
    flight_s: f64,
    on_event: &'a mut dyn FnMut(&TwoPlaneEvent),
    /// The samples of the plane along the hole not yet matched.
    samples: VecDeque<(u64, PlaneState)>,
    /// Where matched samples go, the hole's axes and the (constant) spin.
    on_sample: Option<&'a mut dyn FnMut(&TwoPlaneSample)>,
    /// The sampling grid (its times; unused without sampling).
    grid: Grid,
    axes: [[f64; 2]; 2],
    spin_rad_s: f64,
}

impl Cross<'_> {
    /// Read one message; `false` once the stream has ended.
    fn read(&mut self) -> bool {
        if self.pos == self.batch.len() {
            let mut used = std::mem::take(&mut self.batch);
            if used.capacity() > 0 {
                used.clear();
                // The writing end may be gone; the batch is then dropped here.
                let _ = self.back.send(used);
            }
            match self.rx.recv() {
                Ok(b) => {
                    self.batch = b;
                    self.pos = 0;
                }
                Err(_) => {
                    self.stream_t = f64::INFINITY;
                    return false;
                }
            }
        }
        let m = self.batch[self.pos];
        self.pos += 1;
        match m {
            Msg::Piece(p) => {
                debug_assert!(self.cur.is_none(), "a piece read over one still in use");
                self.stream_t = p.t1;
                self.cur = Some(p);
                true
            }
            Msg::Event(e) => {
                self.stream_t = e.t_s;
                self.pending.push_back(e);
                true
            }
            Msg::Sample(k, p) => {
                self.stream_t = self.grid.time(k);
                self.samples.push_back((k, p));
                true
            }
        }
    }

    /// Report the stream's events up to `t` (all of them for `t = ∞`).
    fn report_until(&mut self, t: f64) {
        while self.stream_t < t && self.read() {}
        while let Some(e) = self.pending.front() {
            if e.t_s > t {
                break;
            }
            let e = self.pending.pop_front().expect("front exists");
            (self.on_event)(&e);
        }
    }

    /// Integrate `u_a u_n` and the flight time over `[a, b]` of a segment of the plane across
    /// the hole, in closed form where both planes' pieces are exponential sums (`sum`, the
    /// segment's, if it is to be used).
    fn integrate(&mut self, seg: &dyn Segment, sum: Option<ExpSum>, a: f64, b: f64, contact: bool) {
        let mut lo = a;
        while lo < b {
            let p = match self.cur {
                Some(p) if p.t1 > lo => p,
                _ => {
                    self.cur = None;
                    if !self.read_piece() {
                        return;
                    }
                    continue;
                }
            };
            let hi = p.t1.min(b);
            self.cross += match (p.shape, sum) {
                (Shape::Sum { x, origin }, Some(y)) => {
                    integral_product_shifted(&x, origin, &y, seg.t_start_s(), lo, hi)
                }
                _ => {
                    let (mid, half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
                    let mut acc = 0.0;
                    for (x, w) in GL8 {
                        let t = mid + half * x;
                        acc += w * p.at(t) * seg.state_at(t).u_m;
                    }
                    half * acc
                }
            };
            if !contact && !p.contact {
                self.flight_s += hi - lo;
            }
            lo = hi;
            if p.t1 <= b {
                self.cur = None;
            }
        }
    }

    /// Put the plane across the hole's sample `k` together with the stream's and report it.
    fn sample(&mut self, k: u64, n: PlaneState) {
        let a = loop {
            match self.samples.front() {
                Some(&(j, p)) if j == k => {
                    self.samples.pop_front();
                    break p;
                }
                // A sample the other plane skipped cannot exist (both walk the same grid over
                // the same time); one past `k` means the stream is ahead.
                Some(&(j, _)) if j < k => {
                    self.samples.pop_front();
                }
                Some(_) => return,
                None => {
                    if !self.read() {
                        return;
                    }
                }
            }
        };
        let [ea, en] = self.axes;
        let frame = |x: f64, y: f64| [x * ea[0] + y * en[0], x * ea[1] + y * en[1]];
        let sample = TwoPlaneSample {
            t_s: self.grid.time(k),
            state: TwoPlaneStart {
                u_m: frame(a.u, n.u),
                du_m_s: frame(a.du, n.du),
                w_hole_m: [a.w, n.w],
                dw_hole_m_s: [a.dw, n.dw],
                spin_rad_s: self.spin_rad_s,
            },
        };
        if let Some(f) = self.on_sample.as_mut() {
            f(&sample);
        }
    }

    /// Read up to the next piece (keeping the events on the way); `false` if the stream ended.
    fn read_piece(&mut self) -> bool {
        while self.read() {
            if self.cur.is_some() {
                return true;
            }
        }
        false
    }
}

impl PlaneObserver<'_> {
    fn energy_j(&self, seg: &dyn Segment, t: f64) -> f64 {
        seg.mechanical_energy_j(t) - self.weight_n * seg.state_at(t).v_m
    }

    fn two_plane_event(&self, ev: &Event) -> Option<TwoPlaneEvent> {
        let wall = |w: Wall| HoleWall::of(self.axis, w.sign());
        let kind = match ev.kind {
            EventKind::Impact {
                wall: w,
                dw_m_s,
                energy_loss_j,
            } => TwoPlaneEventKind::Impact {
                wall: wall(w),
                approach_m_s: dw_m_s.abs(),
                energy_loss_j,
            },
            EventKind::ChatterLimit {
                wall: w,
                energy_loss_j,
            } => TwoPlaneEventKind::Rest {
                wall: wall(w),
                energy_loss_j,
            },
            EventKind::ContactRelease { wall: w } => TwoPlaneEventKind::LiftOff { wall: wall(w) },
            // Frictionless walls: no friction events.
            EventKind::FrictionSwitch | EventKind::Stick | EventKind::Unstick => return None,
        };
        Some(TwoPlaneEvent { t_s: ev.t_s, kind })
    }
    /// The segment's share of the books and the window: totals, and the stream or the cross
    /// term.
    fn window_segment(&mut self, seg: &dyn Segment) {
        let (t0, t1) = (seg.t_start_s(), seg.t_end_s());
        if self.totals.energy_start_j.is_none() {
            self.totals.energy_start_j = Some(self.energy_j(seg, t0));
        }
        if t1 >= self.window.1 {
            // The run's last segment.
            self.totals.energy_end_j = self.energy_j(seg, t1);
        }
        let i = seg.integrals(t0, t1);
        self.totals.forcing_work_j += i.forcing_work_j;
        self.totals.viscous_loss_j += i.viscous_loss_j;
        let (a, b) = (t0.max(self.window.0), t1.min(self.window.1));
        if b <= a {
            return;
        }
        self.totals.u2 += seg.integral_u2(a, b);
        let contact = match seg.mode() {
            Mode::Contact(w) => {
                self.totals.rest_s[usize::from(w == Wall::Minus)] += b - a;
                true
            }
            _ => false,
        };
        let sum = if self.closed_form {
            seg.displacement_sum()
        } else {
            None
        };
        if let (Some(tx), Some(x)) = (&mut self.tx, sum) {
            let piece = Piece {
                t0: a,
                t1: b,
                shape: Shape::Sum { x, origin: t0 },
                contact,
            };
            if !tx.push(Msg::Piece(piece)) {
                self.tx = None;
            }
        } else if let Some(tx) = &mut self.tx {
            let n = ((b - a) / self.h_max_s).ceil().max(1.0) as usize;
            let h = (b - a) / n as f64;
            for k in 0..n {
                let p0 = a + h * k as f64;
                let p1 = if k + 1 == n { b } else { p0 + h };
                let mut u = [0.0; NODES];
                for (j, uj) in u.iter_mut().enumerate() {
                    *uj = seg.state_at(Piece::node(p0, p1, j)).u_m;
                }
                let piece = Piece {
                    t0: p0,
                    t1: p1,
                    shape: Shape::Nodes(u),
                    contact,
                };
                if !tx.push(Msg::Piece(piece)) {
                    self.tx = None;
                    break;
                }
            }
        }
        if let Some(cross) = &mut self.rx {
            cross.integrate(seg, sum, a, b, contact);
        }
    }

    /// The plane along the hole: stream the segment's samples (ahead of its pieces, so that
    /// the reading plane has them once it has read the pieces up to a time).
    fn stream_samples(&mut self, seg: &dyn Segment) {
        let (Some(grid), Some(tx)) = (self.grid.as_mut(), self.tx.as_mut()) else {
            return;
        };
        let mut open = true;
        grid.take(seg, |k, p| open = open && tx.push(Msg::Sample(k, p)));
        if !open {
            self.tx = None;
        }
    }

    /// The plane across the hole: put the segment's samples together with the stream's.
    fn report_samples(&mut self, seg: &dyn Segment) {
        let (Some(grid), Some(cross)) = (self.grid.as_mut(), self.rx.as_mut()) else {
            return;
        };
        grid.take(seg, |k, n| cross.sample(k, n));
    }
}

impl Observer for PlaneObserver<'_> {
    fn segment(&mut self, seg: &dyn Segment) {
        self.stream_samples(seg);
        self.window_segment(seg);
        self.report_samples(seg);
    }

    fn event(&mut self, ev: &Event) {
        match ev.kind {
            EventKind::Impact {
                wall,
                energy_loss_j,
                ..
            } => {
                self.totals.impacts[usize::from(wall == Wall::Minus)] += 1;
                self.totals.impact_loss_j += energy_loss_j;
            }
            EventKind::ChatterLimit { energy_loss_j, .. } => {
                self.totals.impact_loss_j += energy_loss_j;
            }
            _ => {}
        }
        let Some(e) = self.two_plane_event(ev) else {
            return;
        };
        if let Some(tx) = &mut self.tx {
            if !tx.push(Msg::Event(e)) {
                self.tx = None;
            }
        }
        if let Some(cross) = &mut self.rx {
            cross.report_until(e.t_s);
            (cross.on_event)(&e);
        }
    }
}

/// The exact two-plane solver (see the module's documentation for where it applies).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TwoPlaneExact {
    /// The one-plane solver each plane runs on.
    pub plane: Exact,
}

impl TwoPlaneExact {
    /// Run `sys` from `start` over `settings.duration_s` (its `dt_s` is not used), calling
    /// `on_event` at every event in the order of time. Refuses a system whose planes do not
    /// decouple ([`decoupled`]).
    pub fn run(
        &self,
        sys: &TwoPlaneSystem,
        start: &TwoPlaneStart,
        settings: &RunSettings,
        on_event: &mut dyn FnMut(&TwoPlaneEvent),
    ) -> Result<TwoPlaneSummary, SimError> {
        self.run_with(sys, start, None, 0.0, settings, on_event, None, true)
    }

    /// [`TwoPlaneExact::run`] from the state `start` at time `t0_s` (the forcing's phase is
    /// `Ωt0`) over `settings.duration_s`, sampling the state as `sampling` asks (each plane
    /// samples its own closed form on the common grid; the two are put together in the hole's
    /// frame); the RMS window is the last fraction of that span.
    pub fn run_from<'a>(
        &self,
        sys: &TwoPlaneSystem,
        start: &TwoPlaneStart,
        t0_s: f64,
        settings: &RunSettings,
        on_event: &'a mut dyn FnMut(&TwoPlaneEvent),
        sampling: Option<Sampling<'a>>,
    ) -> Result<TwoPlaneSummary, SimError> {
        self.run_with(sys, start, None, t0_s, settings, on_event, sampling, true)
    }

    /// [`TwoPlaneExact::run_from`] on a round bar of modes from each plane's modal state
    /// (`[along the hole, across it]`, at `t0_s`): a start that the public state `start` (the
    /// response point, the ball relative to the cavity) cannot carry, such as a point of a
    /// periodic orbit. `start` must be their public picture; it gives the spin.
    #[allow(clippy::too_many_arguments)]
    pub fn run_from_modal<'a>(
        &self,
        sys: &TwoPlaneSystem,
        start: &TwoPlaneStart,
        modal: &[crate::structure::ModalState; 2],
        t0_s: f64,
        settings: &RunSettings,
        on_event: &'a mut dyn FnMut(&TwoPlaneEvent),
        sampling: Option<Sampling<'a>>,
    ) -> Result<TwoPlaneSummary, SimError> {
        if sys.bar.lumped().is_some() {
            return Err(SimError::Unsupported(
                "modal plane starts are for a round bar of modes; a lumped bar starts from its \
                 public state",
            ));
        }
        self.run_with(
            sys,
            start,
            Some(modal),
            t0_s,
            settings,
            on_event,
            sampling,
            true,
        )
    }

    /// [`TwoPlaneExact::run`], with the cross term from the closed forms where the segments
    /// have them (`closed_form`) or from the streamed nodes everywhere (the check of the first);
    /// the planes start from `modal` where given, else from `start`.
    #[allow(clippy::too_many_arguments)]
    fn run_with<'a>(
        &self,
        sys: &TwoPlaneSystem,
        start: &TwoPlaneStart,
        modal: Option<&[crate::structure::ModalState; 2]>,
        t0_s: f64,
        settings: &RunSettings,
        on_event: &'a mut dyn FnMut(&TwoPlaneEvent),
        sampling: Option<Sampling<'a>>,
        closed_form: bool,
    ) -> Result<TwoPlaneSummary, SimError> {
        sys.validate()?;
        settings.validate()?;
        super::two_plane_rk4::check_start(sys, start)?;
        crate::params::non_negative("start time t0_s", t0_s)?;
        if let Some(sm) = &sampling {
            sm.check(t0_s + settings.duration_s)?;
        }
        let grid = sampling.as_ref().map(|sm| Grid {
            start_s: sm.start_s,
            interval_s: sm.interval_s,
            next_k: 0,
        });
        let on_sample = sampling.map(|sm| sm.on_sample);
        let systems = [plane_system(sys, 0)?, plane_system(sys, 1)?];
        let starts = [
            plane_start(sys, start, 0, t0_s),
            plane_start(sys, start, 1, t0_s),
        ];
        let t_end = t0_s + settings.duration_s;
        let window = (t0_s + settings.window_start_s(), t_end);
        let omega_hi = sys.bar.highest_omega_rad_s().max(sys.omega_rad_s());
        let h_max_s = 1.0 / omega_hi;
        let observer = |axis: usize| PlaneObserver {
            axis,
            window,
            weight_n: sys.ball.mass_kg
                * systems[axis]
                    .damper
                    .map_or(0.0, |d| d.gravity_along_gap_m_s2),
            totals: PlaneTotals::default(),
            tx: None,
            h_max_s,
            closed_form,
            grid,
            rx: None,
        };
        // Each plane's run: from its public state, or from its modal state on the N-mode
        // kernel the one-plane solver would pick.
        let run_plane = |axis: usize, obs: &mut PlaneObserver| -> Result<RunSummary, SimError> {
            match modal {
                None => self.plane.run(&systems[axis], &starts[axis], t_end, obs),
                Some(ms) => {
                    let msys = crate::structure::ModalSystem::from_system(&systems[axis])?;
                    Ok(crate::solver::exact::modal::ModalExact {
                        max_events: self.plane.max_events,
                        check_invariants: self.plane.check_invariants,
                    }
                    .run(&msys, &ms[axis], t_end, obs)?
                    .summary)
                }
            }
        };
        let (tx, rx) = sync_channel(STREAM_BATCHES);
        let (back_tx, back_rx) = channel();
        let (along, across, cross, flight_s) = std::thread::scope(|scope| {
            let producer = scope.spawn(|| {
                let mut obs = PlaneObserver {
                    tx: Some(Stream {
                        tx,
                        back: back_rx,
                        batch: Vec::with_capacity(BATCH),
                    }),
                    ..observer(0)
                };
                let r = run_plane(0, &mut obs);
                if let Some(stream) = &mut obs.tx {
                    stream.flush();
                }
                r.map(|summary| (obs.totals, summary))
            });
            let mut obs = PlaneObserver {
                rx: Some(Cross {
                    rx,
                    back: back_tx,
                    batch: Vec::new(),
                    pos: 0,
                    cur: None,
                    pending: VecDeque::new(),
                    stream_t: f64::NEG_INFINITY,
                    cross: 0.0,
                    flight_s: 0.0,
                    on_event,
                    samples: VecDeque::new(),
                    on_sample,
                    grid: grid.unwrap_or(Grid {
                        start_s: 0.0,
                        interval_s: 1.0,
                        next_k: 0,
                    }),
                    axes: hole_axes(sys),
                    spin_rad_s: start.spin_rad_s,
                }),
                ..observer(1)
            };
            let r = run_plane(1, &mut obs);
            let mut cross = obs.rx.take().expect("the reading end");
            if r.is_ok() {
                // The rest of the stream: the events after the last one across the hole.
                cross.report_until(f64::INFINITY);
            }
            let (c, f) = (cross.cross, cross.flight_s);
            // Dropping the reading end lets a producer still running finish.
            drop(cross);
            let along = producer
                .join()
                .map_err(|_| SimError::Unsupported("the run of the plane along the hole failed"))?;
            Ok::<_, SimError>((along?, (obs.totals, r?), c, f))
        })?;
        summarize(sys, start, &[along, across], cross, flight_s, window)
    }
}

/// The summary of the two planes' totals and runs and their cross integrals.
fn summarize(
    sys: &TwoPlaneSystem,
    start: &TwoPlaneStart,
    planes: &[(PlaneTotals, RunSummary); 2],
    cross: f64,
    flight_s: f64,
    window: (f64, f64),
) -> Result<TwoPlaneSummary, SimError> {
    let len = window.1 - window.0;
    let axes = hole_axes(sys);
    let [(ta, ra), (tn, rn)] = planes;
    let totals = [ta, tn];
    // `∫(c·u)²` for `c` in the hole's frame.
    let rms = |c: [f64; 2]| {
        let s = c[0] * c[0] * ta.u2 + c[1] * c[1] * tn.u2 + 2.0 * c[0] * c[1] * cross;
        (s.max(0.0) / len).sqrt()
    };
    let e_f = direction(sys.forcing.angle_deg);
    let frame = |v: [f64; 2]| [dot(v, axes[0]), dot(v, axes[1])];
    let mut impacts = [0; 4];
    let mut contact_fraction = [[0.0; 3]; 4];
    for axis in 0..2 {
        for side in 0..2 {
            impacts[2 * axis + side] = totals[axis].impacts[side];
            contact_fraction[2 * axis + side][WallMotion::Sliding as usize] =
                totals[axis].rest_s[side] / len;
        }
    }
    let (ea, en) = (ra.final_state, rn.final_state);
    let end = TwoPlaneStart {
        u_m: [
            ea.u_m * axes[0][0] + en.u_m * axes[1][0],
            ea.u_m * axes[0][1] + en.u_m * axes[1][1],
        ],
        du_m_s: [
            ea.du_m_s * axes[0][0] + en.du_m_s * axes[1][0],
            ea.du_m_s * axes[0][1] + en.du_m_s * axes[1][1],
        ],
        w_hole_m: [ea.v_m - ea.u_cavity_m(), en.v_m - en.u_cavity_m()],
        dw_hole_m_s: [
            ea.dv_m_s - ea.du_cavity_m_s(),
            en.dv_m_s - en.du_cavity_m_s(),
        ],
        spin_rad_s: start.spin_rad_s,
    };
    let sum = |f: fn(&PlaneTotals) -> f64| f(ta) + f(tn);
    let book = TwoPlaneBook {
        forcing_work_j: sum(|p| p.forcing_work_j),
        viscous_loss_j: sum(|p| p.viscous_loss_j),
        impact_loss_j: sum(|p| p.impact_loss_j),
        sliding_loss_j: 0.0,
        rolling_loss_j: 0.0,
        energy_change_j: sum(|p| p.energy_end_j - p.energy_start_j.unwrap_or(p.energy_end_j)),
    };
    let cause = "parameters far outside the model's range (forces, masses or stiffness)";
    let fin = |what: &'static str, v: f64| crate::limits::finite_result(what, v, cause);
    Ok(TwoPlaneSummary {
        rms_along_force_m: fin("RMS along the force", rms(frame(e_f)))?,
        rms_m: [
            fin("RMS of u_x", rms(frame([1.0, 0.0])))?,
            fin("RMS of u_y", rms(frame([0.0, 1.0])))?,
        ],
        rms_total_m: fin("RMS of |u|", ((ta.u2 + tn.u2).max(0.0) / len).sqrt())?,
        impacts,
        contact_fraction,
        flight_fraction: flight_s / len,
        events: ra.events + rn.events,
        // |w| − clearance ≥ −clearance: the floor only replaces a plane that never looked.
        max_penetration_m: ra
            .max_penetration_m
            .max(-sys.hole.half_axial_gap_m())
            .max(rn.max_penetration_m.max(-sys.radial_clearance_m())),
        book,
        end,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::two_plane::{Gravity, Hole, PlanarBall, PlanarBar, PlanarForcing};

    /// The paper's bar with the 15 mm ball in a 15.1 mm hole at 20°, the force at 63.4° to it.
    fn system(gap_m: f64, ratio: f64) -> TwoPlaneSystem {
        TwoPlaneSystem {
            bar: PlanarBar::isotropic(&Bar::PAPER_CAVITY).into(),
            ball: PlanarBall::paper_frictionless(),
            hole: Hole {
                angle_deg: 20.0,
                axial_gap_m: gap_m,
                diameter_m: 15.1e-3,
            },
            forcing: PlanarForcing {
                amplitude_n: 15.0,
                frequency: Frequency::Ratio(ratio),
                angle_deg: 83.4,
            },
            gravity: Gravity {
                m_s2: 9.80665,
                angle_deg: 90.0,
            },
            bar_diameter_m: None,
        }
    }

    #[test]
    fn the_closed_form_cross_term_is_the_quadrature_of_the_streamed_nodes() {
        // Impacts on the hole's wall (and on the plugs at the small gap), resting spells,
        // lift-offs: every kind of segment pair.
        // The nodes' interpolants and Gauss–Legendre rule carry ~1e-12 relative error; the
        // closed form none beyond rounding, so the two agree to the quadrature's accuracy and
        // everything that does not involve the cross term is identical.
        let settings = RunSettings {
            duration_s: 0.3,
            dt_s: 1e-6,
            rms_fraction: 0.8,
        };
        let mut plug_impacts = 0;
        for (gap_m, ratio) in [(1e-3, 1.0), (0.1e-3, 1.0), (0.1e-3, 0.97)] {
            let sys = system(gap_m, ratio);
            let start = TwoPlaneStart::resting(&sys, 0.3 * gap_m);
            let solver = TwoPlaneExact::default();
            let mut n = 0;
            let closed = solver
                .run_with(
                    &sys,
                    &start,
                    None,
                    0.0,
                    &settings,
                    &mut |_| n += 1,
                    None,
                    true,
                )
                .unwrap();
            let nodes = solver
                .run_with(&sys, &start, None, 0.0, &settings, &mut |_| {}, None, false)
                .unwrap();
            let i = closed.impacts;
            assert!(i[2] > 0 && i[3] > 0, "{i:?}");
            plug_impacts += i[0] + i[1];
            assert_eq!(closed.events, n);
            for (a, b, what) in [
                (closed.rms_along_force_m, nodes.rms_along_force_m, "along"),
                (closed.rms_m[0], nodes.rms_m[0], "x"),
                (closed.rms_m[1], nodes.rms_m[1], "y"),
            ] {
                assert!((a - b).abs() <= 1e-10 * b, "{what}: {a} {b}");
            }
            assert_eq!(closed.rms_total_m.to_bits(), nodes.rms_total_m.to_bits());
            assert_eq!(closed.impacts, nodes.impacts);
            assert!((closed.flight_fraction - nodes.flight_fraction).abs() <= 1e-12);
        }
        assert!(plug_impacts > 0);
    }
}
