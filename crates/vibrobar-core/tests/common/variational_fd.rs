//! Central finite differences of the lumped exact solver's end state, in scaled coordinates:
//! the reference the variational layer's Jacobian is checked against. Shared by
//! `variational.rs`, `variational_hertz.rs` and `variational_params.rs`, which include it with
//! `#[path]` (each uses a part).
#![allow(dead_code)]

use vibrobar_core::analysis::variational::Mat4;
use vibrobar_core::params::{State, System};
use vibrobar_core::solver::{Exact, Solver};

/// Scales of `(u, u̇, v, v̇)`: the FD steps and the norm of the comparison.
pub fn scales(sys: &System) -> [f64; 4] {
    let bar = sys.lumped_bar().unwrap();
    let su = sys.forcing.amplitude_n / bar.stiffness_n_per_m;
    let wn = bar.natural_freq_rad_s();
    [su, wn * su, su, wn * su]
}

pub fn end(sys: &System, x: &State, t_end: f64) -> [f64; 4] {
    let s = Exact::default()
        .run(sys, x, t_end, &mut ())
        .unwrap()
        .final_state;
    [s.u_m, s.du_m_s, s.v_m, s.dv_m_s]
}

pub fn set(x: &State, j: usize, d: f64) -> State {
    let mut y = *x;
    match j {
        0 => y.u_m += d,
        1 => y.du_m_s += d,
        2 => y.v_m += d,
        _ => y.dv_m_s += d,
    }
    y
}

/// Central differences with relative step `h` (in units of the scales); returns the FD
/// Jacobian in scaled coordinates.
pub fn fd_jacobian(sys: &System, x: &State, t_end: f64, h: f64, dirs: &[usize]) -> Mat4 {
    let sc = scales(sys);
    let mut j = [[0.0; 4]; 4];
    for &c in dirs {
        let d = h * sc[c];
        let (p, m) = (
            end(sys, &set(x, c, d), t_end),
            end(sys, &set(x, c, -d), t_end),
        );
        for r in 0..4 {
            j[r][c] = (p[r] - m[r]) / (2.0 * d) * sc[c] / sc[r];
        }
    }
    j
}

pub fn scaled(sys: &System, j: &Mat4) -> Mat4 {
    let sc = scales(sys);
    let mut o = *j;
    for r in 0..4 {
        for c in 0..4 {
            o[r][c] = j[r][c] * sc[c] / sc[r];
        }
    }
    o
}

/// Largest entry error over the largest entry, over the columns `dirs`.
pub fn rel_err(a: &Mat4, b: &Mat4, dirs: &[usize]) -> f64 {
    let (mut e, mut n) = (0.0f64, 0.0f64);
    for r in 0..4 {
        for &c in dirs {
            e = e.max((a[r][c] - b[r][c]).abs());
            n = n.max(a[r][c].abs());
        }
    }
    e / n
}
