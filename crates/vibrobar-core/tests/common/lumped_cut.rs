//! The lumped bar of the cutting tests (600 Hz, 2.2e6 N/m, ζ = 0.01) without harmonic forcing,
//! and the cut's coefficient and feed: one definition for `cutting.rs`, `cutting_event_slope.rs`,
//! `cutting_hertz.rs`, `modal_cutting_hertz.rs`, `time_domain.rs` and `lobe_design.rs`, which include it with
//! `#[path]`.
#![allow(dead_code)]

use vibrobar_core::params::{Bar, BarModel, Damper, Forcing, Frequency, System};

pub const F_HZ: f64 = 600.0;
pub const K: f64 = 2.2e6;
pub const ZETA: f64 = 0.01;
pub const KF: f64 = 2e9;
pub const H0: f64 = 1e-4;

pub fn wn() -> f64 {
    2.0 * std::f64::consts::PI * F_HZ
}

pub fn bar() -> Bar {
    Bar {
        mass_kg: K / (wn() * wn()),
        stiffness_n_per_m: K,
        damping_ratio: ZETA,
    }
}

/// The bar with `damper`, unforced (the cut is the only force).
pub fn sys(damper: Option<Damper>) -> System {
    System {
        bar: BarModel::Lumped(bar()),
        damper,
        forcing: Forcing {
            amplitude_n: 0.0,
            frequency: Frequency::Ratio(1.0),
            static_force_n: 0.0,
        },
        gravity_m_s2: 9.81,
    }
}
