//! The symmetric two-impacts-per-cycle periodic orbit (Masri & Caughey type) of the frictionless
//! lumped bar, derived for this model independently of the solver (the shared VALIDATION.md).
//!
//! At the `+` impact (time `t0`): bar at `u0`, velocities `u̇−`, `u̇+`; the ball arrives with `V`
//! and leaves with `−V`. Antisymmetry `u(t+T/2) = −u(t)`, `v(t+T/2) = −v(t)` gives
//! `v0 = u0 + l_g = V T/4`; the impact map gives `u̇+ = u̇− + 2μV` and
//! `−V − u̇+ = −e(V − u̇−)`; the bar flows freely over `T/2`:
//! `Φ(T/2)[u0 − p, u̇+ − ṗ] = [−u0 + p, −u̇− + ṗ]` with the steady state `p = X sin θ`,
//! `ṗ = XΩ cos θ`, `θ = Ωt0 − ψ`. For each θ the first four equations are linear in
//! `(u0, u̇−, u̇+, V)`; the last one is a residual in θ whose zeros are the orbits. A zero is kept
//! when the ball arrives toward the wall and stays inside the cavity over the half period.
//!
//! It applies to a lumped bar with a frictionless ball, the restitution law and no static load
//! ([`symmetric_orbits`] refuses anything else): it is the independent reference of
//! [`super::find_orbit`] and a starting guess for it.

use crate::error::SimError;
use crate::params::{ContactLaw, FrictionModel, State, System};

/// One symmetric orbit, at its `+` impact.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SymmetricOrbit {
    /// Time of the `+` impact, in `[0, T)`.
    pub t0: f64,
    /// Bar displacement at the impact.
    pub u0: f64,
    /// Bar velocity before the impact.
    pub du_minus: f64,
    /// Bar velocity after the impact.
    pub du_plus: f64,
    /// Ball speed `V` (absolute) between impacts: it arrives with `+V`, leaves with `−V`.
    pub v_ball: f64,
}

impl SymmetricOrbit {
    /// The state just after the `+` impact (ball on the `+` wall, leaving it).
    pub fn state_after_impact(&self, sys: &System) -> State {
        let lg = sys.damper.map_or(0.0, |d| d.half_gap_m());
        let mut s = State {
            t_s: self.t0,
            u_m: self.u0,
            du_m_s: self.du_plus,
            v_m: self.u0 + lg,
            dv_m_s: -self.v_ball,
            cavity: None,
        };
        // Keep w = v − u within [−l_g, l_g] despite rounding.
        while s.w_m() > lg {
            s.v_m = f64::from_bits(s.v_m.to_bits() - 1);
        }
        s
    }

    /// The state a quarter period after the `+` impact, midway between the two impacts (the
    /// best place for a stroboscopic section: no event near it), in closed form.
    pub fn state_at_quarter(&self, sys: &System) -> State {
        let c = consts(sys);
        let s = 0.25 * c.t;
        let (u, du) = c.bar_flow(self.t0, self.u0, self.du_plus, s);
        let lg = c.lg;
        State {
            t_s: self.t0 + s,
            u_m: u,
            du_m_s: du,
            v_m: self.u0 + lg - self.v_ball * s,
            dv_m_s: -self.v_ball,
            cavity: None,
        }
    }

    /// Relative impact speed `V − u̇−`.
    pub fn impact_speed_m_s(&self) -> f64 {
        self.v_ball - self.du_minus
    }

    /// RMS of the bar displacement over the period, in closed form (Simpson's rule on 2000
    /// intervals of the half period, whose error is far below 1e-12 of the RMS).
    pub fn rms_m(&self, sys: &System) -> f64 {
        let c = consts(sys);
        let half = 0.5 * c.t;
        let n = 2000;
        let h = half / n as f64;
        let f = |i: usize| {
            let (u, _) = c.bar_flow(self.t0, self.u0, self.du_plus, h * i as f64);
            u * u
        };
        let mut s = f(0) + f(n);
        for i in 1..n {
            s += if i % 2 == 1 { 4.0 } else { 2.0 } * f(i);
        }
        // u² is T/2-periodic (antisymmetry): the half period is the whole mean.
        (s * h / 3.0 / half).sqrt()
    }
}

/// Why [`symmetric_orbits`] refuses a system.
pub const SYMMETRIC_ORBIT_SCOPE: &str = "the analytic symmetric orbit is derived for a lumped bar with a frictionless ball (friction none), the restitution law, no static load and no body force on the ball (damper.gravity_along_gap_m_s2 = 0)";

#[derive(Debug, Clone, Copy)]
struct Consts {
    mu: f64,
    e: f64,
    lg: f64,
    om: f64,
    t: f64,
    x: f64,
    psi: f64,
    al: f64,
    wn2: f64,
    wd: f64,
}

fn consts(sys: &System) -> Consts {
    let d = sys.damper.unwrap_or_default();
    let bar = sys.lumped_bar().copied().unwrap_or_default();
    let (m, k, c) = (bar.mass_kg, bar.stiffness_n_per_m, bar.damping_n_s_per_m());
    let om = sys.omega_rad_s();
    let al = c / (2.0 * m);
    let wn2 = k / m;
    Consts {
        mu: d.ball_mass_kg / m,
        e: d.restitution,
        lg: d.half_gap_m(),
        om,
        t: 2.0 * std::f64::consts::PI / om,
        x: sys.forcing.amplitude_n / ((k - m * om * om).powi(2) + (c * om).powi(2)).sqrt(),
        psi: (c * om).atan2(k - m * om * om),
        al,
        wn2,
        wd: (wn2 - al * al).sqrt(),
    }
}

impl Consts {
    /// Bar displacement and velocity `s` after time `t0` where it is at `(u0, du0)`, ball free.
    fn bar_flow(&self, t0: f64, u0: f64, du0: f64, s: f64) -> (f64, f64) {
        let (om, x, psi, al, wd) = (self.om, self.x, self.psi, self.al, self.wd);
        let up = |t: f64| x * (om * t - psi).sin();
        let dup = |t: f64| x * om * (om * t - psi).cos();
        let (y0, y1) = (u0 - up(t0), du0 - dup(t0));
        let b = (y1 + al * y0) / wd;
        let ex = (-al * s).exp();
        let (sn, cs) = (wd * s).sin_cos();
        let u = up(t0 + s) + ex * (y0 * cs + b * sn);
        let du = dup(t0 + s) + ex * (-al * (y0 * cs + b * sn) + wd * (-y0 * sn + b * cs));
        (u, du)
    }
}

fn solve4(mut a: [[f64; 5]; 4]) -> [f64; 4] {
    // Plain fixed-bound loops: this is the inner step of the phase scan (millions of calls),
    // and indexed loops compile to the same code whatever the crate around them looks like.
    for col in 0..4 {
        // The largest pivot, the last of equals.
        let mut piv = col;
        for i in col + 1..4 {
            if a[i][col].abs().total_cmp(&a[piv][col].abs()).is_ge() {
                piv = i;
            }
        }
        a.swap(col, piv);
        let pivot_row = a[col];
        for (row, r) in a.iter_mut().enumerate() {
            if row != col {
                let f = r[col] / pivot_row[col];
                for k in col..5 {
                    r[k] -= f * pivot_row[k];
                }
            }
        }
    }
    [0, 1, 2, 3].map(|i| a[i][4] / a[i][i])
}

/// Every admissible symmetric orbit of `sys` (usually none or two), in order of the impact
/// phase. Refuses ([`SimError::Unsupported`]) a system outside [`SYMMETRIC_ORBIT_SCOPE`].
pub fn symmetric_orbits(sys: &System) -> Result<Vec<SymmetricOrbit>, SimError> {
    sys.validate()?;
    let applies = sys.lumped_bar().is_some()
        && sys.forcing.static_force_n == 0.0
        && sys.damper.is_some_and(|d| {
            d.contact.law == ContactLaw::Restitution
                && d.friction == FrictionModel::None
                && d.gravity_along_gap_m_s2 == 0.0
        });
    if !applies {
        return Err(SimError::Unsupported(SYMMETRIC_ORBIT_SCOPE));
    }
    let c = consts(sys);
    let (mu, e, lg, om, t, x) = (c.mu, c.e, c.lg, c.om, c.t, c.x);
    let s = t / 2.0;
    let ex = (-c.al * s).exp();
    let (sn, cs) = (c.wd * s).sin_cos();
    let p11 = ex * (cs + c.al / c.wd * sn);
    let p12 = ex * sn / c.wd;
    let p21 = -ex * c.wn2 / c.wd * sn;
    let p22 = ex * (cs - c.al / c.wd * sn);
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
        let t0 = ((th + c.psi) / om).rem_euclid(t);
        let o = SymmetricOrbit {
            t0,
            u0,
            du_minus,
            du_plus,
            v_ball,
        };
        if admissible(&c, &o) {
            out.push(o);
        }
    }
    Ok(out)
}

/// Ball arrives toward the wall, and stays inside the cavity over the half period.
fn admissible(c: &Consts, o: &SymmetricOrbit) -> bool {
    if o.v_ball - o.du_minus <= 0.0 || o.v_ball <= 0.0 {
        return false;
    }
    let half = std::f64::consts::PI / c.om;
    let n = 2000;
    (1..n).all(|i| {
        let s = half * i as f64 / n as f64;
        let (u, _) = c.bar_flow(o.t0, o.u0, o.du_plus, s);
        let v = o.u0 + c.lg - o.v_ball * s;
        (v - u).abs() <= c.lg
    })
}
