//! Steady-state impact regime of a run, as a short word for a CSV `regime` column.
//!
//! [`RegimeObserver`] collects, over a window (normally the RMS window), the impacts (time, wall),
//! the stroboscopic points at forcing phase 0 and the time spent in each [`Mode`]. The pure
//! [`classify`] turns that [`Collected`] into a [`Regime`]:
//!
//! 1. `contact`: the ball spends more than `contact_fraction` of the window sticking to the bar
//!    or riding against a wall (`Mode::Stick`, `Mode::Contact`). `rk4` never reports these modes;
//!    event-driven solvers do.
//! 2. `none`: no impact in the window.
//! 3. `p{n}/{k}` for the smallest period `k ≤ k_max` (in forcing cycles) such that
//!    * the impact sequence repeats after `n` impacts: impact `j + n` is on the same wall as impact
//!      `j` and `|t_{j+n} − t_j − kT| ≤ phase_tol·T` for every `j`; `n` counts the impacts in
//!      `[t_first, t_first + kT − phase_tol·T)`; the first and last impacts lie within
//!      `kT + phase_tol·T` of the window edges (impacts that stop or start mid-window are not
//!      periodic);
//!    * the stroboscopic points repeat after `k`: `|u_{i+k} − u_i| ≤ state_rel·max|u|` and
//!      `|u̇_{i+k} − u̇_i| ≤ state_rel·max|u̇|` for every `i` (skipped when there are none, as
//!      in synthetic collections);
//!    * the window holds at least `min_repeats·k` forcing cycles.
//! 4. `sym2`: the case `n = 2, k = 1` where consecutive impacts alternate walls and are half a
//!    period apart: `|t_{j+1} − t_j − T/2| ≤ phase_tol·T`.
//! 5. `chaotic`: impacts, but no period up to `k_max` (this also covers quasi-periodic motion).
//!
//! `rk4` has no contact mode: a ball resting against a wall is reported as an impact at every
//! step (chatter). For the paper's frictionless 0.1 mm case at r = 1 this makes impacts per cycle
//! grow like 1/dt (≈ 6.5, 24, 390 at dt = 1e-6, 1e-7, 1e-8 s) while the RMS converges; such runs
//! classify as `chaotic`. Event-driven solvers report the chatter limit and `Mode::Contact`.
//!
//! Default tolerances ([`Tolerances::default`]): `phase_tol = 0.01` (1 % of a period: `rk4` at
//! dt = 1 µs places impacts on its step grid, ≈ 0.06 % of the paper's ≈ 1.7 ms period),
//! `state_rel = 0.01`, `k_max = 8`, `min_repeats = 3`, `contact_fraction = 0.5`.

use super::poincare::Stroboscope;
use crate::params::{State, System};
use crate::solver::{Event, EventKind, Mode, Observer, Segment, Wall};
use std::borrow::Cow;

/// A steady-state regime.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Regime {
    /// No impact in the window.
    None,
    /// Symmetric two impacts per cycle: one per wall, half a period apart, periodic.
    Sym2,
    /// Periodic with `impacts` impacts per `cycles` forcing cycles.
    Periodic {
        /// Impacts per period (`n`).
        impacts: u32,
        /// Period in forcing cycles (`k`).
        cycles: u32,
    },
    /// Sticking or wall contact dominates.
    Contact,
    /// Impacts with no period up to `k_max` forcing cycles.
    Chaotic,
}

impl Regime {
    /// The word for the CSV column: `none`, `sym2`, `p{n}/{k}`, `contact`, `chaotic`.
    pub fn as_str(&self) -> Cow<'static, str> {
        match self {
            Regime::None => "none".into(),
            Regime::Sym2 => "sym2".into(),
            Regime::Periodic { impacts, cycles } => format!("p{impacts}/{cycles}").into(),
            Regime::Contact => "contact".into(),
            Regime::Chaotic => "chaotic".into(),
        }
    }

    /// Parse [`Regime::as_str`] back (for resuming from a CSV).
    pub fn parse(s: &str) -> Option<Regime> {
        match s {
            "none" => Some(Regime::None),
            "sym2" => Some(Regime::Sym2),
            "contact" => Some(Regime::Contact),
            "chaotic" => Some(Regime::Chaotic),
            _ => {
                let (n, k) = s.strip_prefix('p')?.split_once('/')?;
                Some(Regime::Periodic {
                    impacts: n.parse().ok()?,
                    cycles: k.parse().ok()?,
                })
            }
        }
    }
}

impl std::fmt::Display for Regime {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.as_str())
    }
}

/// Tolerances of [`classify`]; see the module documentation. Deserialised with missing fields
/// from [`Tolerances::default`] (so metadata can persist and reload them).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Tolerances {
    /// Impact-time tolerance, as a fraction of the forcing period.
    pub phase_tol: f64,
    /// Stroboscopic-point tolerance, relative to the largest `|u|` (and `|u̇|`) in the window.
    pub state_rel: f64,
    /// Largest period tried, in forcing cycles.
    pub k_max: u32,
    /// The window must hold at least `min_repeats·k` cycles to call period `k`.
    pub min_repeats: u32,
    /// Fraction of the window in stick/contact modes above which the regime is `contact`.
    pub contact_fraction: f64,
}

impl Default for Tolerances {
    fn default() -> Self {
        Tolerances {
            phase_tol: 0.01,
            state_rel: 0.01,
            k_max: 8,
            min_repeats: 3,
            contact_fraction: 0.5,
        }
    }
}

/// One impact, as the classifier needs it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImpactRecord {
    /// Time.
    pub t_s: f64,
    /// Wall.
    pub wall: Wall,
}

/// Time spent in each mode inside the window.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ModeTime {
    /// `Mode::NoBall`.
    pub no_ball_s: f64,
    /// `Mode::Free`.
    pub free_s: f64,
    /// `Mode::Stick`.
    pub stick_s: f64,
    /// `Mode::Contact(_)`.
    pub contact_s: f64,
}

impl ModeTime {
    /// Fraction of the observed time in `Stick` or `Contact` (0 when nothing was observed).
    pub fn stick_contact_fraction(&self) -> f64 {
        let total = self.no_ball_s + self.free_s + self.stick_s + self.contact_s;
        if total > 0.0 {
            (self.stick_s + self.contact_s) / total
        } else {
            0.0
        }
    }
}

/// What the classifier needs from a run's window.
#[derive(Debug, Clone, PartialEq)]
pub struct Collected {
    /// Forcing period `T`.
    pub period_s: f64,
    /// Window start.
    pub window_start_s: f64,
    /// Window end.
    pub window_end_s: f64,
    /// Impacts in the window, in time order.
    pub impacts: Vec<ImpactRecord>,
    /// Stroboscopic points (forcing phase 0) in the window.
    pub strobe: Vec<State>,
    /// Time per mode in the window.
    pub mode_time: ModeTime,
}

impl Collected {
    /// Number of whole forcing cycles in the window.
    pub fn whole_cycles(&self) -> usize {
        ((self.window_end_s - self.window_start_s) / self.period_s + 1e-9).floor() as usize
    }

    /// Impacts in each whole forcing cycle `[t_w + cT, t_w + (c+1)T)` of the window.
    pub fn impacts_per_cycle(&self) -> Vec<u32> {
        let n = self.whole_cycles();
        let mut counts = vec![0u32; n];
        for i in &self.impacts {
            let c = ((i.t_s - self.window_start_s) / self.period_s).floor();
            if c >= 0.0 && (c as usize) < n {
                counts[c as usize] += 1;
            }
        }
        counts
    }

    /// Histogram of [`Collected::impacts_per_cycle`]: entry `m` is the number of whole cycles with
    /// exactly `m` impacts.
    pub fn impacts_per_cycle_histogram(&self) -> Vec<u64> {
        let per = self.impacts_per_cycle();
        let max = per.iter().copied().max().unwrap_or(0) as usize;
        let mut h = vec![0u64; max + 1];
        for c in per {
            h[c as usize] += 1;
        }
        h
    }
}

/// Observer that fills a [`Collected`] over `[window_start, window_end]`.
#[derive(Debug, Clone, PartialEq)]
pub struct RegimeObserver {
    collected: Collected,
    strobe: Stroboscope,
}

impl RegimeObserver {
    /// Collect for `sys` over `[window_start_s, window_end_s]`.
    pub fn new(sys: &System, window_start_s: f64, window_end_s: f64) -> Self {
        let period_s = sys.forcing_period_s();
        RegimeObserver {
            collected: Collected {
                period_s,
                window_start_s,
                window_end_s,
                impacts: Vec::new(),
                strobe: Vec::new(),
                mode_time: ModeTime::default(),
            },
            strobe: Stroboscope::new(period_s, 0.0, window_start_s, window_end_s),
        }
    }

    /// The collection.
    pub fn finish(self) -> Collected {
        Collected {
            strobe: self.strobe.points,
            ..self.collected
        }
    }
}

impl Observer for RegimeObserver {
    fn segment(&mut self, seg: &dyn Segment) {
        self.strobe.segment(seg);
        let c = &mut self.collected;
        let a = seg.t_start_s().max(c.window_start_s);
        let b = seg.t_end_s().min(c.window_end_s);
        if b > a {
            let mt = &mut c.mode_time;
            match seg.mode() {
                Mode::NoBall => mt.no_ball_s += b - a,
                Mode::Free => mt.free_s += b - a,
                Mode::Stick => mt.stick_s += b - a,
                Mode::Contact(_) => mt.contact_s += b - a,
            }
        }
    }

    fn event(&mut self, ev: &Event) {
        let c = &mut self.collected;
        if let EventKind::Impact { wall, .. } = ev.kind {
            if ev.t_s >= c.window_start_s && ev.t_s <= c.window_end_s {
                c.impacts.push(ImpactRecord { t_s: ev.t_s, wall });
            }
        }
    }
}

/// Classify a collection; see the module documentation for the rules.
pub fn classify(c: &Collected, tol: &Tolerances) -> Regime {
    if c.mode_time.stick_contact_fraction() > tol.contact_fraction {
        return Regime::Contact;
    }
    if c.impacts.is_empty() {
        return Regime::None;
    }
    let cycles = (c.window_end_s - c.window_start_s) / c.period_s;
    for k in 1..=tol.k_max {
        if cycles < f64::from(tol.min_repeats * k) {
            break;
        }
        if let Some(n) = impact_period(c, k, tol) {
            if strobe_periodic(&c.strobe, k as usize, tol.state_rel) {
                if k == 1 && n == 2 && symmetric(c, tol) {
                    return Regime::Sym2;
                }
                return Regime::Periodic {
                    impacts: n,
                    cycles: k,
                };
            }
        }
    }
    Regime::Chaotic
}

/// `Some(n)` when the impact sequence repeats every `k` cycles with `n` impacts per repeat.
fn impact_period(c: &Collected, k: u32, tol: &Tolerances) -> Option<u32> {
    let imp = &c.impacts;
    let t = c.period_s;
    let kt = f64::from(k) * t;
    let slack = tol.phase_tol * t;
    let first = imp.first()?.t_s;
    let last = imp.last()?.t_s;
    if first - c.window_start_s > kt + slack || c.window_end_s - last > kt + slack {
        return None;
    }
    let n = imp
        .iter()
        .take_while(|i| i.t_s < first + kt - slack)
        .count();
    if n == 0 || imp.len() <= n {
        return None;
    }
    let ok = imp
        .iter()
        .zip(&imp[n..])
        .all(|(a, b)| a.wall == b.wall && (b.t_s - a.t_s - kt).abs() <= slack);
    ok.then_some(n as u32)
}

pub(crate) fn strobe_periodic(pts: &[State], k: usize, rel: f64) -> bool {
    let umax = pts.iter().fold(0.0f64, |m, s| m.max(s.u_m.abs()));
    let vmax = pts.iter().fold(0.0f64, |m, s| m.max(s.du_m_s.abs()));
    pts.iter().zip(pts.iter().skip(k)).all(|(a, b)| {
        (b.u_m - a.u_m).abs() <= rel * umax && (b.du_m_s - a.du_m_s).abs() <= rel * vmax
    })
}

fn symmetric(c: &Collected, tol: &Tolerances) -> bool {
    let half = 0.5 * c.period_s;
    c.impacts.windows(2).all(|p| {
        p[0].wall != p[1].wall && (p[1].t_s - p[0].t_s - half).abs() <= tol.phase_tol * c.period_s
    })
}
