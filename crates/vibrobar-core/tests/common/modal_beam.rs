//! The paper's beam as a modal system and independent references on it (a mode's closed-form
//! forced response, the kinetic energy of bar and ball): shared by `modal_exact.rs`,
//! `modal_rk4.rs`, `modal_hertz.rs`, `orbit_modal.rs` and `variational_modal.rs`, which include
//! it with `#[path]` (each uses a part).
#![allow(dead_code)]

use vibrobar_core::solver::Event;
use vibrobar_core::structure::{Beam, ModalModel, ModalState, ModalSystem, Structure};
use vibrobar_core::*;

/// The paper's bar (L = 175 mm, D = 25 mm, steel, ζ = 0.01) with `n` modes, cavity 38 mm from
/// the free end, force and response at the tip.
pub fn beam_system(n: usize, damper: Option<Damper>, ratio: f64) -> ModalSystem {
    ModalSystem {
        model: Structure::Beam(Beam {
            modes: Some(n),
            ..Beam::default()
        })
        .modal_model()
        .unwrap(),
        damper,
        forcing: Forcing::paper(ratio),
        gravity_m_s2: params::STANDARD_GRAVITY_M_S2,
    }
}

/// Exact response of one mode `m(q̈ + 2ζωq̇ + ω²q) = φ_f F0 sin Ωt` from rest: `(q, q̇)` at `t`.
pub fn mode_closed_form(m: &structure::Mode, f0: f64, omega: f64, t: f64) -> (f64, f64) {
    let (wn, z, mm) = (m.omega_rad_s, m.damping_ratio, m.modal_mass_kg);
    let g = num_complex::Complex64::new(wn * wn - omega * omega, 2.0 * z * wn * omega) * mm;
    let h = 1.0 / g;
    let a = m.shape_force * f0;
    // Particular: q_p = a (Re H sin Ωt + Im H cos Ωt).
    let (s, c) = (omega * t).sin_cos();
    let qp = a * (h.re * s + h.im * c);
    let dqp = a * omega * (h.re * c - h.im * s);
    // Homogeneous from q(0) = q̇(0) = 0.
    let wd = wn * (1.0 - z * z).sqrt();
    let c1 = -a * h.im;
    let c2 = (z * wn * c1 - a * omega * h.re) / wd;
    let ex = (-z * wn * t).exp();
    let (sd, cd) = (wd * t).sin_cos();
    let qh = ex * (c1 * cd + c2 * sd);
    let dqh = ex * (-z * wn * (c1 * cd + c2 * sd) + wd * (-c1 * sd + c2 * cd));
    (qp + qh, dqp + dqh)
}

/// The kinetic energy of the modes and the ball.
pub fn kinetic_j(sys: &ModalSystem, s: &ModalState) -> f64 {
    let md = sys.damper.unwrap().ball_mass_kg;
    sys.model
        .modes()
        .iter()
        .enumerate()
        .map(|(i, m)| 0.5 * m.modal_mass_kg * s.dq_m_s[i] * s.dq_m_s[i])
        .sum::<f64>()
        + 0.5 * md * s.dv_m_s * s.dv_m_s
}

/// The one-mode beam with the ball at the tip, and the lumped bar of its mode: the same motion
/// (shapes 1 at force, response and cavity, to rounding).
pub fn one_mode_tip_model() -> ModalModel {
    let beam = Beam {
        modes: Some(1),
        cavity_position_m: Beam::default().length_m,
        ..Beam::default()
    };
    Structure::Beam(beam).modal_model().unwrap()
}

/// The lumped bar of `model`'s one mode with `damper`, and the modal system of `model` with it.
pub fn lumped_and_modal(model: ModalModel, damper: Damper) -> (System, ModalSystem) {
    let m1 = model.modes()[0];
    let lumped_sys = System {
        bar: Bar {
            mass_kg: m1.modal_mass_kg,
            stiffness_n_per_m: m1.modal_stiffness_n_per_m(),
            damping_ratio: m1.damping_ratio,
        }
        .into(),
        damper: Some(damper),
        forcing: Forcing::paper(1.0),
        gravity_m_s2: params::STANDARD_GRAVITY_M_S2,
    };
    let msys = ModalSystem {
        model,
        damper: Some(damper),
        forcing: lumped_sys.forcing,
        gravity_m_s2: lumped_sys.gravity_m_s2,
    };
    (lumped_sys, msys)
}

/// The largest state difference of two runs on the same grid (per field, relative to the
/// field's largest value in `a`) and the largest event time difference times `om`.
pub fn run_differences(
    a: &[State],
    b: &[State],
    ea: &[Event],
    eb: &[Event],
    om: f64,
) -> (f64, f64) {
    let mut worst = 0.0f64;
    let fields: [&dyn Fn(&State) -> f64; 4] =
        [&|s| s.u_m, &|s| s.du_m_s, &|s| s.v_m, &|s| s.dv_m_s];
    for f in fields {
        let sc = a.iter().map(|s| f(s).abs()).fold(0.0, f64::max);
        for (x, y) in a.iter().zip(b) {
            worst = worst.max((f(x) - f(y)).abs() / sc);
        }
    }
    let worst_t = ea
        .iter()
        .zip(eb)
        .map(|(x, y)| (x.t_s - y.t_s).abs() * om)
        .fold(0.0, f64::max);
    (worst, worst_t)
}

/// The relative errors of one impact `b → a` that removed the energy `loss`: momentum
/// `mₙq̇ₙ + φₙ(x_d) m_d v̇` (the largest over the modes; rounding is relative to the larger side,
/// an impact can start a quiet mode), kinetic energy against `loss`, and `ẇ+ = −e ẇ−`.
pub fn impact_errors(
    sys: &ModalSystem,
    b: &ModalState,
    a: &ModalState,
    loss: f64,
) -> (f64, f64, f64) {
    let d = sys.damper.unwrap();
    let mut worst_p = 0.0f64;
    for (i, m) in sys.model.modes().iter().enumerate() {
        let p = |s: &ModalState| {
            (
                m.modal_mass_kg * s.dq_m_s[i] + m.shape_cavity * d.ball_mass_kg * s.dv_m_s,
                (m.modal_mass_kg * s.dq_m_s[i]).abs()
                    + (m.shape_cavity * d.ball_mass_kg * s.dv_m_s).abs(),
            )
        };
        let ((pb, sb), (pa, sa)) = (p(b), p(a));
        worst_p = worst_p.max((pa - pb).abs() / sb.max(sa));
    }
    let (kb, ka) = (kinetic_j(sys, b), kinetic_j(sys, a));
    let e = ((kb - ka) - loss).abs() / kb;
    let (wb, wa) = (b.dw_m_s(&sys.model), a.dw_m_s(&sys.model));
    let scale = b.dv_m_s.abs()
        + sys
            .model
            .modes()
            .iter()
            .enumerate()
            .map(|(i, m)| (m.shape_cavity * b.dq_m_s[i]).abs())
            .sum::<f64>();
    (worst_p, e, (wa + d.restitution * wb).abs() / scale)
}
