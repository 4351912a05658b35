//! Symmetric two-impacts-per-cycle periodic orbit (Masri & Caughey type), frictionless,
//! derived for this model independently of the solver.
//!
//! At the `+` impact (time `t0`): bar at `u0`, velocities `u̇−`, `u̇+`; the ball arrives with `V`
//! and leaves with `−V`. Antisymmetry `u(t+T/2) = −u(t)`, `v(t+T/2) = −v(t)` gives
//! `v0 = u0 + l_g = V T/4`; the impact map gives `u̇+ = u̇− + 2μV` and
//! `−V − u̇+ = −e(V − u̇−)`; the bar flows freely over `T/2`:
//! `Φ(T/2)[u0 − p, u̇+ − ṗ] = [−u0 + p, −u̇− + ṗ]` with the steady state `p = X sin θ`,
//! `ṗ = XΩ cos θ`, `θ = Ωt0 − ψ`. For each θ the first four equations are linear in
//! `(u0, u̇−, u̇+, V)`; the last one is a residual in θ whose zeros are the orbits.

use vibrobar_core::*;

/// One orbit.
#[derive(Debug, Clone, Copy)]
pub struct Orbit {
    pub t0: f64,
    pub u0: f64,
    pub du_minus: f64,
    pub du_plus: f64,
    pub v_ball: f64,
}

fn solve4(mut a: [[f64; 5]; 4]) -> [f64; 4] {
    for col in 0..4 {
        let piv = (col..4)
            .max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))
            .unwrap();
        a.swap(col, piv);
        for row in 0..4 {
            if row != col {
                let f = a[row][col] / a[col][col];
                let pivot_row = a[col];
                for (x, p) in a[row].iter_mut().zip(pivot_row).skip(col) {
                    *x -= f * p;
                }
            }
        }
    }
    [0, 1, 2, 3].map(|i| a[i][4] / a[i][i])
}

pub fn orbits(sys: &System) -> Vec<Orbit> {
    let d = sys.damper.unwrap();
    let (m, k, c) = (
        sys.lumped_bar().unwrap().mass_kg,
        sys.lumped_bar().unwrap().stiffness_n_per_m,
        sys.lumped_bar().unwrap().damping_n_s_per_m(),
    );
    let (mu, e, lg) = (d.ball_mass_kg / m, d.restitution, d.half_gap_m());
    let om = sys.omega_rad_s();
    let t = 2.0 * std::f64::consts::PI / om;
    let x = sys.forcing.amplitude_n / ((k - m * om * om).powi(2) + (c * om).powi(2)).sqrt();
    let psi = (c * om).atan2(k - m * om * om);
    let al = c / (2.0 * m);
    let wn2 = k / m;
    let wd = (wn2 - al * al).sqrt();
    let s = t / 2.0;
    let ex = (-al * s).exp();
    let (sn, cs) = (wd * s).sin_cos();
    let p11 = ex * (cs + al / wd * sn);
    let p12 = ex * sn / wd;
    let p21 = -ex * wn2 / wd * sn;
    let p22 = ex * (cs - al / wd * sn);
    // Unknowns (u0, u̇−, u̇+, V); eqs (1)–(4); returns them and the residual of (5).
    let at = |th: f64| -> ([f64; 4], f64) {
        let (sv, cv) = th.sin_cos();
        let (p, pd) = (x * sv, x * om * cv);
        let sol = solve4([
            [-4.0 / t, 0.0, 0.0, 1.0, 4.0 * lg / t],
            [0.0, -1.0, 1.0, -2.0 * mu, 0.0],
            [0.0, -e, -1.0, e - 1.0, 0.0],
            [p11 + 1.0, 0.0, p12, 0.0, (p11 + 1.0) * p + p12 * pd],
        ]);
        let [u0, dum, dup, _] = sol;
        let r = p21 * (u0 - p) + p22 * (dup - pd) + dum - pd;
        (sol, r)
    };
    let n = 20_000;
    let mut out = Vec::new();
    let two_pi = 2.0 * std::f64::consts::PI;
    for i in 0..n {
        let (mut a, mut b) = (
            two_pi * i as f64 / n as f64,
            two_pi * (i + 1) as f64 / n as f64,
        );
        let (mut ra, rb) = (at(a).1, at(b).1);
        if ra.signum() == rb.signum() {
            continue;
        }
        for _ in 0..200 {
            let mid = 0.5 * (a + b);
            let rm = at(mid).1;
            if rm.signum() == ra.signum() {
                a = mid;
                ra = rm;
            } else {
                b = mid;
            }
        }
        let th = 0.5 * (a + b);
        let ([u0, du_minus, du_plus, v_ball], _) = at(th);
        let t0 = ((th + psi) / om).rem_euclid(t);
        let o = Orbit {
            t0,
            u0,
            du_minus,
            du_plus,
            v_ball,
        };
        if admissible(sys, &o, x, psi) {
            out.push(o);
        }
    }
    out
}

/// Ball arrives toward the wall, and stays inside the cavity over the half period.
fn admissible(sys: &System, o: &Orbit, x: f64, psi: f64) -> bool {
    let lg = sys.damper.unwrap().half_gap_m();
    let om = sys.omega_rad_s();
    if o.v_ball - o.du_minus <= 0.0 || o.v_ball <= 0.0 {
        return false;
    }
    let (m, k, c) = (
        sys.lumped_bar().unwrap().mass_kg,
        sys.lumped_bar().unwrap().stiffness_n_per_m,
        sys.lumped_bar().unwrap().damping_n_s_per_m(),
    );
    let al = c / (2.0 * m);
    let wd = (k / m - al * al).sqrt();
    let up = |t: f64| x * (om * t - psi).sin();
    let dup = |t: f64| x * om * (om * t - psi).cos();
    let (y0, y1) = (o.u0 - up(o.t0), o.du_plus - dup(o.t0));
    let half = std::f64::consts::PI / om;
    let n = 2000;
    (1..n).all(|i| {
        let s = half * i as f64 / n as f64;
        let u = up(o.t0 + s)
            + (-al * s).exp() * (y0 * (wd * s).cos() + (y1 + al * y0) / wd * (wd * s).sin());
        let v = o.u0 + lg - o.v_ball * s;
        (v - u).abs() <= lg
    })
}
