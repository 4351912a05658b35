//! Shared helpers of the `exact_*` tests: a recording observer and test systems.
#![allow(dead_code)]

pub mod golden;
pub mod orbit;

use vibrobar_core::solver::{Event, EventKind, Mode, Observer, Segment, SegmentIntegrals};
use vibrobar_core::*;

/// Records events, the end points of every segment, and the summed integrals.
#[derive(Default)]
pub struct Recorder {
    pub events: Vec<Event>,
    /// (t_start, t_end, mode, integrals over the whole segment, state at start, state at end).
    pub segs: Vec<(f64, f64, Mode, SegmentIntegrals, State, State)>,
    pub totals: SegmentIntegrals,
}

impl Observer for Recorder {
    fn segment(&mut self, seg: &dyn Segment) {
        let (a, b) = (seg.t_start_s(), seg.t_end_s());
        let i = seg.integrals(a, b);
        self.totals += i;
        self.segs
            .push((a, b, seg.mode(), i, seg.state_at(a), seg.state_at(b)));
    }
    fn event(&mut self, ev: &Event) {
        self.events.push(*ev);
    }
}

impl Recorder {
    pub fn impacts(&self) -> Vec<&Event> {
        self.events
            .iter()
            .filter(|e| matches!(e.kind, EventKind::Impact { .. }))
            .collect()
    }
    pub fn count(&self, f: impl Fn(&EventKind) -> bool) -> usize {
        self.events.iter().filter(|e| f(&e.kind)).count()
    }
    pub fn losses_j(&self) -> f64 {
        self.events
            .iter()
            .map(|e| match e.kind {
                EventKind::Impact { energy_loss_j, .. } => energy_loss_j,
                EventKind::ChatterLimit { energy_loss_j, .. } => energy_loss_j,
                _ => 0.0,
            })
            .sum()
    }
}

/// Den Hartog's case: a 1 kg bar on 1e4 N/m, undamped, with Coulomb friction `f` to ground (a
/// 1e9 kg ball in a 100 m gap: it never impacts), forced by 1 N at ratio `r`. Returns the
/// system and the static deflection `F0/k`.
pub fn friction_to_ground(r: f64, f: f64) -> (System, f64) {
    let k = 1e4;
    let sys = System {
        bar: Bar {
            mass_kg: 1.0,
            stiffness_n_per_m: k,
            damping_ratio: 0.0,
        }
        .into(),
        damper: Some(Damper {
            ball_mass_kg: 1e9,
            friction_force_n: Some(f),
            ..Damper::paper(100.0, FrictionModel::Coulomb)
        }),
        forcing: Forcing {
            amplitude_n: 1.0,
            frequency: Frequency::Ratio(r),
            static_force_n: 0.0,
        },
        gravity_m_s2: 9.81,
    };
    (sys, 1.0 / k)
}

/// A bar with a constant load and a vanishing spring: the relative acceleration of a free ball
/// is constant, `ẅ = −F_s/M`.
pub fn constant_push(static_force_n: f64, gap_m: f64, restitution: f64) -> System {
    System {
        bar: Bar {
            mass_kg: 1.0,
            stiffness_n_per_m: 1e-9,
            damping_ratio: 0.0,
        }
        .into(),
        damper: Some(Damper {
            ball_mass_kg: 0.05,
            ball_radius_m: 0.0075,
            restitution,
            gap_m,
            rolling_friction_m: 0.0,
            friction: FrictionModel::None,
            friction_force_n: None,
            contact: vibrobar_core::Contact::default(),
            gravity_along_gap_m_s2: 0.0,
        }),
        forcing: Forcing {
            amplitude_n: 0.0,
            frequency: Frequency::RadPerS(1.0),
            static_force_n,
        },
        gravity_m_s2: STANDARD_GRAVITY_M_S2,
    }
}

pub use vibrobar_core::params::STANDARD_GRAVITY_M_S2;

/// The bar alone (the ball never moves: frictionless, from rest, centred, no impact) from rest,
/// in closed form: `u(t)`, `u̇(t)`.
pub fn linear_bar_from_rest(sys: &System, t: f64) -> (f64, f64) {
    let (m, c, k) = (
        sys.lumped_bar().unwrap().mass_kg,
        sys.lumped_bar().unwrap().damping_n_s_per_m(),
        sys.lumped_bar().unwrap().stiffness_n_per_m,
    );
    let (f0, w) = (sys.forcing.amplitude_n, sys.omega_rad_s());
    let (re, im) = (k - m * w * w, c * w);
    let (x, phi) = (f0 / re.hypot(im), im.atan2(re));
    let sigma = c / (2.0 * m);
    let wd = (k / m - sigma * sigma).sqrt();
    // From rest: A = X sin φ, B = (−XΩ cos φ + σA)/ω_d.
    let a = x * phi.sin();
    let b = (-x * w * phi.cos() + sigma * a) / wd;
    let e = (-sigma * t).exp();
    let (s, co) = (wd * t).sin_cos();
    let u = x * (w * t - phi).sin() + e * (a * co + b * s);
    let du = x * w * (w * t - phi).cos() + e * (-sigma * (a * co + b * s) + wd * (-a * s + b * co));
    (u, du)
}
