//! The lumped bar's side of the variational layer ([`super`], whose module docs derive it): the
//! 4×4 transition matrices in closed form, the restitution and plastic resets, the compliant
//! phase's field and Jacobian in contact coordinates, the parameter column, and the flows
//! ([`flow_with_jacobian`], [`flow_with_param_derivative`]). Every map goes to a
//! [`TangentSink`] as a [`Mat4`].

use super::{
    contact_partials, det4, mat_mul, tangent_advance, ContactPhase, EventCounts, EventMap,
    JacobianSink, Laws, Mat4, Param, Phase, Step, TangentBar, TangentSink, Variational,
    HERTZ_TANGENT_RTOL, IDENTITY, VARIATIONAL_NEEDS_BALL,
};
use crate::damper::friction::sliding_friction_on_ball_n;
use crate::error::SimError;
use crate::params::{FrictionModel, State, System};
use crate::solver::dopri5::Dopri5;
use crate::solver::{
    CompliantContact, Event, EventKind, Mode, Observer, RunSummary, Segment, Solver,
};

/// Why the variational layer refuses a modal bar.
pub const VARIATIONAL_LUMPED_ONLY: &str = "this variational layer is the lumped bar's (4×4 tangent maps); the N-mode bar's 2N+2-dimensional tangent map is analysis::variational::modal";
/// Why the variational layer refuses a parameter derivative under the Hertz law.
pub const VARIATIONAL_NO_HERTZ_PARAM: &str = "the parameter column of the variational flow covers the instantaneous restitution law; under the hertz law take central differences of the map (orbit::continuation::map_param_derivative_fd)";

/// `(u, u̇, v, v̇)` of a state.
fn vec_of(s: &State) -> [f64; 4] {
    [s.u_m, s.du_m_s, s.v_m, s.dv_m_s]
}

/// The lumped bar of the variational layer: its constants, the parameter column and the
/// compliant phase's tangent block.
#[derive(Debug, Clone, Copy)]
pub struct LumpedBar {
    m: f64,
    k: f64,
    c: f64,
    laws: Laws,
    /// The parameter whose derivative column `∂x/∂p` is carried (none by default).
    param: Option<Param>,
    /// `∂x/∂p` on `(u, u̇, v, v̇)` at the current time (zero at the start).
    dxdp: [f64; 4],
    /// The compliant phase's `[W | ζ]`, one 4×5 block row-major (`z[5i + j]`, `j = 4` the
    /// `δ̇₀` column), and the tangent step size to try next.
    z: [f64; 20],
    h: f64,
}

impl LumpedBar {
    fn mu_ratio(&self) -> f64 {
        self.laws.md / (self.m + self.laws.md)
    }

    /// `e^{−ατ}`-form transition matrix of the bar of mass `mass` over `τ` (2×2).
    fn bar_phi(&self, mass: f64, tau: f64) -> [[f64; 2]; 2] {
        let al = self.c / (2.0 * mass);
        let wn2 = self.k / mass;
        let wd = (wn2 - al * al).sqrt();
        let ex = (-al * tau).exp();
        let (s, co) = (wd * tau).sin_cos();
        let sw = s / wd;
        [
            [ex * (co + al * sw), ex * sw],
            [-wn2 * ex * sw, ex * (co - al * sw)],
        ]
    }

    /// `(u_p, u̇_p)(t)`: a particular solution of `mass ü + C u̇ + K u = F₀ t cos Ωt`,
    /// `Re[F₀ e^{st} (t/D − D'/D²)]`, `s = iΩ`, `D(s) = mass s² + C s + K` (differentiate
    /// `L e^{st} = D(s) e^{st}` in `s`).
    fn secular_particular(&self, mass: f64, t: f64) -> [f64; 2] {
        use nalgebra::Complex;
        let sj = Complex::new(0.0, self.laws.om);
        let d = sj * sj * mass + sj * self.c + self.k;
        let dp = sj * (2.0 * mass) + self.c;
        let est = Complex::new(0.0, self.laws.om * t).exp() * self.laws.f0;
        let a = Complex::new(t, 0.0) / d - dp / (d * d);
        let u = est * a;
        let du = est * (sj * a + Complex::new(1.0, 0.0) / d);
        [u.re, du.re]
    }

    /// `∫ Φ(τ − s) (0, F₀ s cos Ωs / mass) ds` over `[t0, t1]`, from zero.
    fn secular_response(&self, mass: f64, t0: f64, t1: f64) -> [f64; 2] {
        let (a, b) = (
            self.secular_particular(mass, t0),
            self.secular_particular(mass, t1),
        );
        let p = self.bar_phi(mass, t1 - t0);
        [
            b[0] - p[0][0] * a[0] - p[0][1] * a[1],
            b[1] - p[1][0] * a[0] - p[1][1] * a[1],
        ]
    }

    /// The projection onto the constrained motion of phase `mode` (identity in free flight).
    fn projection(&self, mode: Mode) -> Mat4 {
        let r = self.mu_ratio();
        match mode {
            Mode::Free | Mode::NoBall => IDENTITY,
            Mode::Stick => [
                [1.0, 0.0, 0.0, 0.0],
                [0.0, 1.0 - r, 0.0, r],
                [0.0, 0.0, 1.0, 0.0],
                [0.0, 1.0 - r, 0.0, r],
            ],
            Mode::Contact(_) => [
                [1.0, 0.0, 0.0, 0.0],
                [0.0, 1.0 - r, 0.0, r],
                [1.0, 0.0, 0.0, 0.0],
                [0.0, 1.0 - r, 0.0, r],
            ],
        }
    }

    /// Transition matrix of a segment of phase `mode` and length `τ`.
    fn segment_stm(&self, mode: Mode, tau: f64) -> Mat4 {
        match mode {
            Mode::Free | Mode::NoBall => {
                let p = self.bar_phi(self.m, tau);
                [
                    [p[0][0], p[0][1], 0.0, 0.0],
                    [p[1][0], p[1][1], 0.0, 0.0],
                    [0.0, 0.0, 1.0, tau],
                    [0.0, 0.0, 0.0, 1.0],
                ]
            }
            Mode::Stick | Mode::Contact(_) => {
                let p = self.bar_phi(self.m + self.laws.md, tau);
                // v(τ) = u(τ) + (v₀ − u₀), v̇ = u̇; then the projection at the start.
                let pair = [
                    [p[0][0], p[0][1], 0.0, 0.0],
                    [p[1][0], p[1][1], 0.0, 0.0],
                    [p[0][0] - 1.0, p[0][1], 1.0, 0.0],
                    [p[1][0], p[1][1], 0.0, 0.0],
                ];
                mat_mul(&pair, &self.projection(mode))
            }
        }
    }

    /// Restitution map on `(u̇, v̇)` as a 4×4 `G` (positions kept).
    fn restitution_g(&self) -> Mat4 {
        // u̇⁺ = u̇ + β(v̇ − u̇), v̇⁺ = u̇⁺ − e(v̇ − u̇), β = μ(1+e)/(1+μ), μ = m_d/M.
        let mu = self.laws.md / self.m;
        let beta = mu * (1.0 + self.laws.e) / (1.0 + mu);
        [
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0 - beta, 0.0, beta],
            [0.0, 0.0, 1.0, 0.0],
            [0.0, 1.0 - beta + self.laws.e, 0.0, beta - self.laws.e],
        ]
    }

    /// `G = ∂g/∂x` of the plastic limit (common momentum-conserving velocity).
    fn plastic_g(&self) -> Mat4 {
        let r = self.mu_ratio();
        [
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0 - r, 0.0, r],
            [0.0, 0.0, 1.0, 0.0],
            [0.0, 1.0 - r, 0.0, r],
        ]
    }
}

impl LumpedBar {
    /// `A = ∂f/∂y` of the compliant phase's field and `b = ∂f/∂δ̇₀` (the law's reference speed).
    /// With `P = K_h δ^{3/2}(1 + D δ̇/δ̇₀)`: `P_δ = (3/2) K_h δ^{1/2}(1 + D δ̇/δ̇₀)`,
    /// `P_δ̇ = K_h δ^{3/2} D/δ̇₀`, `P_δ̇₀ = −K_h δ^{3/2} D δ̇/δ̇₀²` (all 0 at `δ ≤ 0`).
    fn hz_jac(&self, c: &CompliantContact, y: &[f64; 4]) -> (Mat4, [f64; 4]) {
        if c.stuck {
            let mt = self.m + self.laws.md;
            return (
                [
                    [0.0, 1.0, 0.0, 0.0],
                    [-self.k / mt, -self.c / mt, 0.0, 0.0],
                    [0.0, 0.0, 0.0, 0.0],
                    [0.0, 0.0, 0.0, 0.0],
                ],
                [0.0; 4],
            );
        }
        let sw = c.wall_sign;
        let (p_d, p_dd, p_v0) = contact_partials(c, y[2], y[3]);
        let (m, md) = (self.m, self.laws.md);
        let inv = 1.0 / m + 1.0 / md;
        (
            [
                [0.0, 1.0, 0.0, 0.0],
                [-self.k / m, -self.c / m, sw * p_d / m, sw * p_dd / m],
                [0.0, 0.0, 0.0, 1.0],
                [sw * self.k / m, sw * self.c / m, -p_d * inv, -p_dd * inv],
            ],
            [0.0, sw * p_v0 / m, 0.0, -p_v0 * inv],
        )
    }
}

/// `S = G + (f⁺ − G f⁻) ∇hᵀ / rate`, `rate = ∇h·f⁻ + ∂h/∂t`. Returns `None` when the rate
/// vanishes (grazing).
fn saltation(
    g: &Mat4,
    f_minus: &[f64; 4],
    f_plus: &[f64; 4],
    grad_h: &[f64; 4],
    rate: f64,
) -> Option<Mat4> {
    if rate == 0.0 || !rate.is_finite() {
        return None;
    }
    let mut gf = [0.0; 4];
    for i in 0..4 {
        gf[i] = (0..4).map(|j| g[i][j] * f_minus[j]).sum();
    }
    let mut s = *g;
    for i in 0..4 {
        let d = (f_plus[i] - gf[i]) / rate;
        for j in 0..4 {
            s[i][j] += d * grad_h[j];
        }
    }
    Some(s)
}

/// `m · d`.
#[inline]
fn mat_vec(m: &Mat4, d: &[f64; 4]) -> [f64; 4] {
    [0, 1, 2, 3].map(|i| m[i][0] * d[0] + m[i][1] * d[1] + m[i][2] * d[2] + m[i][3] * d[3])
}

impl LumpedBar {
    /// The inhomogeneous part of `∂x/∂p` over a segment of `mode` and length `τ`, from zero:
    /// `∫₀^τ Φ(τ − s) ∂f/∂p ds`. Only the friction level enters a vector field (the ball's
    /// sliding force `b F`, `b = ∂F_ball/∂F`, constant over a free flight).
    fn segment_param_term(&self, mode: Mode, sigma: f64, t0: f64, t1: f64) -> [f64; 4] {
        let tau = t1 - t0;
        match (self.param, mode) {
            (Some(Param::FreqRatio), Mode::Free | Mode::NoBall) => {
                let r = self.secular_response(self.m, t0, t1);
                [r[0] * self.laws.om1, r[1] * self.laws.om1, 0.0, 0.0]
            }
            (Some(Param::FreqRatio), Mode::Stick | Mode::Contact(_)) => {
                // The pair moves as one body; the ball follows at fixed w.
                let r = self.secular_response(self.m + self.laws.md, t0, t1);
                let (a, b) = (r[0] * self.laws.om1, r[1] * self.laws.om1);
                [a, b, a, b]
            }
            (Some(Param::FrictionForceN), Mode::Free) => {
                let b = sliding_friction_on_ball_n(self.laws.model, 1.0, sigma);
                // Bar: M ü + C u̇ + K u = −b, from rest: (I − Φ(τ)) (−b/K, 0).
                let p = self.bar_phi(self.m, tau);
                let up = -b / self.k;
                // Ball: v̈ = b/m_d.
                let a = b / self.laws.md;
                [
                    (1.0 - p[0][0]) * up,
                    -p[1][0] * up,
                    0.5 * a * tau * tau,
                    a * tau,
                ]
            }
            (Some(Param::GapM), Mode::Contact(wall)) => {
                // On the wall `v = u + s l_g`: the projection keeps `δw = 0`, the offset
                // `∂w/∂gap = s/2` (`l_g = gap/2`) is restored here.
                [0.0, 0.0, 0.5 * wall.sign(), 0.0]
            }
            _ => [0.0; 4],
        }
    }

    /// The parameter column's jump at an event: `d⁺ = S d⁻ + ∂g/∂p + (f⁺ − G f⁻) (∂h/∂p) /
    /// rate` (module docs, "Parameter derivatives").
    fn param_jump(&mut self, p: Param, e: &EventMap<[f64; 4], Mat4>, salt: Option<&Mat4>) {
        let (g, t, rate) = (&e.g, e.t_s, e.rate);
        let mut q = [0.0; 4];
        if p == Param::FreqRatio
            && matches!(
                e.kind,
                EventKind::Unstick | EventKind::ContactRelease { .. }
            )
            && salt.is_some()
        {
            // h = r (F(t) − C u̇ − K u) − threshold: ∂h/∂ratio = r F₀ t cos Ωt · ω₁.
            let r = self.laws.md / (self.m + self.laws.md);
            let dh = r * self.laws.f0 * t * (self.laws.om * t).cos() * self.laws.om1;
            let gf = mat_vec(g, &e.f_minus);
            for i in 0..4 {
                q[i] = (e.f_plus[i] - gf[i]) * dh / rate;
            }
        }
        if let EventKind::Impact { wall, .. } = e.kind {
            let dw = e.x[3] - e.x[1];
            match p {
                Param::Restitution if !e.plastic => {
                    let mu = self.laws.md / self.m;
                    let db = mu / (1.0 + mu) * dw;
                    q[1] = db;
                    q[3] = db - dw;
                }
                Param::GapM if salt.is_some() => {
                    let gf = mat_vec(g, &e.f_minus);
                    // h = w − s l_g with l_g = gap/2.
                    let dh = -0.5 * wall.sign();
                    for i in 0..4 {
                        q[i] = (e.f_plus[i] - gf[i]) * dh / rate;
                    }
                }
                _ => {}
            }
        }
        // Unstick and release: `h` holds the friction level only for Coulomb, where
        // `f⁺ = f⁻` at the threshold, so the term vanishes; no other event's `h` or `g`
        // depends on these parameters.
        let d = mat_vec(salt.unwrap_or(g), &self.dxdp);
        self.dxdp = [0, 1, 2, 3].map(|i| d[i] + q[i]);
    }
}

impl<T: TangentSink> TangentBar<T> for LumpedBar {
    type X = [f64; 4];
    type G = Mat4;
    fn dim(&self) -> usize {
        4
    }
    fn zero(&self) -> [f64; 4] {
        [0.0; 4]
    }
    fn laws(&self) -> &Laws {
        &self.laws
    }
    fn contact_mass_kg(&self) -> f64 {
        self.m * self.laws.md / (self.m + self.laws.md)
    }
    fn event_state(&self, _: &T, ev: &Event) -> [f64; 4] {
        vec_of(&ev.before)
    }
    fn state_at_start(&self, _: &T, seg: &dyn Segment, t0: f64) -> [f64; 4] {
        vec_of(&seg.state_at(t0))
    }
    /// `f = (u̇, ü, v̇, v̈)`.
    fn field(&self, p: Phase, x: &[f64; 4], t: f64) -> [f64; 4] {
        let free = self.laws.force(t) - self.c * x[1] - self.k * x[0];
        match p.mode {
            Mode::Free | Mode::NoBall => {
                let fb = self.laws.fb(p.sigma);
                [
                    x[1],
                    (free - fb) / self.m,
                    x[3],
                    fb / self.laws.md + self.laws.gs,
                ]
            }
            Mode::Stick | Mode::Contact(_) => {
                let a = (free + self.laws.md * self.laws.gs) / (self.m + self.laws.md);
                [x[1], a, x[3], a]
            }
        }
    }

    fn dw(&self, x: &[f64; 4]) -> f64 {
        x[3] - x[1]
    }
    fn grad_w(&self) -> [f64; 4] {
        [-1.0, 0.0, 1.0, 0.0]
    }
    fn grad_dw(&self) -> [f64; 4] {
        [0.0, -1.0, 0.0, 1.0]
    }
    fn hold_release(&self, t: f64, f_minus: &[f64; 4]) -> ([f64; 4], f64) {
        // h = f_l − q·m_d ü_pair with ü_pair = (F(t) − C u̇ − K u)/(M + m_d); only the
        // direction of ∇h and the rate matter up to a common factor.
        let r = self.laws.md / (self.m + self.laws.md);
        let grad = [-self.k * r, -self.c * r, 0.0, 0.0];
        let rate = grad[0] * f_minus[0] + grad[1] * f_minus[1] + r * self.laws.dforce_dt(t);
        (grad, rate)
    }
    fn identity_g(&self) -> Mat4 {
        IDENTITY
    }
    fn impact_g(&self, plastic: bool) -> Mat4 {
        if plastic {
            self.plastic_g()
        } else {
            self.restitution_g()
        }
    }
    fn after_reset(&self, _: &Mat4, plastic: bool, ev: &Event, x: &[f64; 4]) -> [f64; 4] {
        let mut xp = vec_of(&ev.after);
        if plastic {
            let v = (1.0 - self.mu_ratio()) * x[1] + self.mu_ratio() * x[3];
            xp[1] = v;
            xp[3] = v;
        }
        xp
    }
    fn segment_map(&mut self, sink: &mut T, seg: &dyn Segment, mode: Mode, t0: f64, t1: f64) {
        let m = self.segment_stm(mode, t1 - t0);
        if self.param.is_some() {
            // The friction sign even at a zero level (the derivative there is not zero).
            let sig = if mode == Mode::Free && self.laws.model != FrictionModel::None {
                crate::damper::friction::sgn0(seg.state_at(0.5 * (t0 + t1)).dw_m_s())
            } else {
                0.0
            };
            let q = self.segment_param_term(mode, sig, t0, t1);
            let d = mat_vec(&m, &self.dxdp);
            self.dxdp = [0, 1, 2, 3].map(|i| d[i] + q[i]);
        }
        sink.apply(
            &m,
            Step::Segment {
                t0_s: t0,
                t1_s: t1,
                mode,
            },
        );
    }
    fn event_map(&mut self, sink: &mut T, e: &EventMap<[f64; 4], Mat4>) {
        let salt = saltation(&e.g, &e.f_minus, &e.f_plus, &e.grad_h, e.rate);
        if let (Some(p), false) = (self.param, e.release) {
            self.param_jump(p, e, salt.as_ref());
        }
        sink.apply(
            salt.as_ref().unwrap_or(&e.g),
            Step::Event {
                t_s: e.t_s,
                kind: e.kind,
                plastic: e.plastic,
            },
        );
    }
    fn mark(&mut self, sink: &mut T, step: Step) {
        sink.apply(&IDENTITY, step);
    }

    fn contact_coords(&self, sw: f64, x: &[f64; 4]) -> [f64; 4] {
        [
            x[0],
            x[1],
            sw * (x[2] - x[0]) - self.laws.lg,
            sw * (x[3] - x[1]),
        ]
    }
    fn public_tangent(&self, sw: f64, z: &[f64; 4]) -> [f64; 4] {
        [z[0], z[1], z[0] + sw * z[2], z[1] + sw * z[3]]
    }
    /// The compliant phase's vector field in contact coordinates (`hertz.rs`):
    /// `M ü = F(t) − C u̇ − K u + sw P − F_b`, `m_d v̈ = −sw P + F_b`, `δ̈ = sw (v̈ − ü)`; stuck:
    /// the pair moves as one body at fixed `δ`.
    fn hz_field(&self, c: &CompliantContact, t: f64, y: &[f64; 4]) -> [f64; 4] {
        let free = self.laws.force(t) - self.c * y[1] - self.k * y[0];
        if c.stuck {
            let a = (free + self.laws.md * self.laws.gs) / (self.m + self.laws.md);
            return [y[1], a, 0.0, 0.0];
        }
        let sw = c.wall_sign;
        let p = c.law.force_n(y[2], y[3], c.reference_speed_m_s);
        let fb = c.ball_friction_n;
        let ddu = (free + sw * p - fb) / self.m;
        let ddv = (-sw * p + fb) / self.laws.md + self.laws.gs;
        [y[1], ddu, y[3], sw * (ddv - ddu)]
    }

    fn hz_unstick(
        &self,
        sw: f64,
        c: &CompliantContact,
        t: f64,
        y: &[f64; 4],
        f_minus: &[f64; 4],
    ) -> ([f64; 4], f64) {
        let r = self.laws.md / (self.m + self.laws.md);
        let kh = c.law.stiffness_n_m32;
        let g = [
            -self.k * r,
            -self.c * r,
            sw * 1.5 * kh * y[2].max(0.0).sqrt(),
            0.0,
        ];
        let rate = (0..4).map(|i| g[i] * f_minus[i]).sum::<f64>() + r * self.laws.dforce_dt(t);
        (g, rate)
    }
    fn hz_col(&self, j: usize) -> [f64; 4] {
        [0, 1, 2, 3].map(|i| self.z[5 * i + j])
    }
    fn hz_set_col(&mut self, j: usize, z: &[f64; 4]) {
        for (i, zi) in z.iter().enumerate() {
            self.z[5 * i + j] = *zi;
        }
    }
    fn hz_begin(&mut self, h0: f64) {
        self.h = h0;
    }
    /// The block integrated at once: `Z' = A(t) Z + [0 | b(t)]`, relative tolerance
    /// [`HERTZ_TANGENT_RTOL`] on every entry.
    fn hz_advance(
        &mut self,
        ph: &ContactPhase<[f64; 4]>,
        seg: &dyn Segment,
    ) -> Result<(), SimError> {
        let (sw, info) = (ph.sw, &ph.last);
        // Entry (i, j) maps a perturbation of size `col_j` to one of size `row_i`.
        let mut atol = [0.0; 20];
        for i in 0..4 {
            for j in 0..5 {
                atol[5 * i + j] = HERTZ_TANGENT_RTOL * ph.row_scale(1, i) / ph.col_scale(1, j);
            }
        }
        let ig = Dopri5::<20>::new(HERTZ_TANGENT_RTOL, atol);
        let bar = *self;
        let f = |t: f64, z: &[f64; 20]| {
            let y = TangentBar::<T>::contact_coords(&bar, sw, &vec_of(&seg.state_at(t)));
            let (am, bv) = bar.hz_jac(info, &y);
            let mut dz = [0.0; 20];
            for i in 0..4 {
                for j in 0..5 {
                    let mut acc = if j == 4 { bv[i] } else { 0.0 };
                    for k in 0..4 {
                        acc += am[i][k] * z[5 * k + j];
                    }
                    dz[5 * i + j] = acc;
                }
            }
            dz
        };
        let (a, b) = (seg.t_start_s(), seg.t_end_s());
        tangent_advance(&ig, f, a, b, &mut self.z, &mut self.h)
    }
    fn phase_map(&mut self, sink: &mut T, ph: &ContactPhase<[f64; 4]>, t_end: f64) -> Option<f64> {
        let mut w = [[0.0; 4]; 4];
        let mut wm = [[0.0; 4]; 4];
        for i in 0..4 {
            for j in 0..4 {
                w[i][j] = self.z[5 * i + j];
                wm[i][j] = w[i][j] + self.z[5 * i + 4] * ph.c[j];
            }
        }
        let (dw, dm) = (det4(&w), det4(&wm));
        let sw = ph.sw;
        let t_inv = [
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [1.0, 0.0, sw, 0.0],
            [0.0, 1.0, 0.0, sw],
        ];
        sink.apply(
            &mat_mul(&t_inv, &wm),
            Step::Segment {
                t0_s: ph.t0,
                t1_s: t_end,
                mode: ph.mode,
            },
        );
        (dw != 0.0 && dm != 0.0 && (dm / dw).is_finite()).then_some(dm / dw)
    }
}

impl<T: TangentSink> Variational<T, LumpedBar> {
    /// The layer for `sys` (lumped bar with a damper, either contact law).
    pub fn new(sys: &System, sink: T) -> Result<Self, SimError> {
        sys.validate()?;
        let bar = sys
            .lumped_bar()
            .ok_or(SimError::Unsupported(VARIATIONAL_LUMPED_ONLY))?;
        let d = sys
            .damper
            .ok_or(SimError::Unsupported(VARIATIONAL_NEEDS_BALL))?;
        let laws = Laws::new(
            &d,
            sys.friction_level_n(),
            &sys.forcing,
            sys.omega_rad_s(),
            sys.omega1_rad_s(),
        );
        let bar = LumpedBar {
            m: bar.mass_kg,
            k: bar.stiffness_n_per_m,
            c: bar.damping_n_s_per_m(),
            laws,
            param: None,
            dxdp: [0.0; 4],
            z: [0.0; 20],
            h: 0.0,
        };
        Ok(Variational::with_bar(bar, sink))
    }

    /// Also carry the column `∂x/∂p` of parameter `p` (from zero at the start). Restitution
    /// law only: under the `hertz` law the column is not built ([`flow_with_param_derivative`]
    /// refuses it).
    pub fn with_param(mut self, p: Param) -> Self {
        self.bar.param = Some(p);
        self
    }

    /// `∂x/∂p` so far (zero when no parameter is carried).
    pub fn dx_dp(&self) -> [f64; 4] {
        self.bar.dxdp
    }
}

/// The end state of a run, its Jacobian and the events it went through.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlowJacobian {
    /// The state at `t_end_s`.
    pub state: State,
    /// `∂x(t_end)/∂x(t₀)` on `x = (u, u̇, v, v̇)`, at fixed start and end times.
    pub jacobian: Mat4,
    /// The vector field at the end, `∂x(t_end)/∂t_end` (for a phase condition or a period
    /// derivative).
    pub end_field: [f64; 4],
    /// The events the tangent map went through.
    pub events: EventCounts,
    /// The solver's summary.
    pub summary: RunSummary,
}

/// Run the exact solver `solver` (any other is refused) on `sys` from `init` to `t_end_s` and return the end state with
/// the Jacobian of the flow map (the stroboscopic map over `k` forcing periods is
/// `t_end_s = init.t_s + k·T`). `extra` sees the run too (`&mut ()` for nothing).
pub fn flow_with_jacobian(
    solver: &dyn Solver,
    sys: &System,
    init: &State,
    t_end_s: f64,
    extra: &mut dyn Observer,
) -> Result<FlowJacobian, SimError> {
    flow_tangent(solver, sys, init, t_end_s, None, extra).map(|(f, _)| f)
}

/// [`flow_with_jacobian`] plus `∂x(t_end)/∂p` at fixed start state and times, on
/// `(u, u̇, v, v̇)`.
pub fn flow_with_param_derivative(
    solver: &dyn Solver,
    sys: &System,
    init: &State,
    t_end_s: f64,
    param: Param,
    extra: &mut dyn Observer,
) -> Result<(FlowJacobian, [f64; 4]), SimError> {
    flow_tangent(solver, sys, init, t_end_s, Some(param), extra)
}

fn flow_tangent(
    solver: &dyn Solver,
    sys: &System,
    init: &State,
    t_end_s: f64,
    param: Option<Param>,
    extra: &mut dyn Observer,
) -> Result<(FlowJacobian, [f64; 4]), SimError> {
    super::require_exact(solver)?;
    let mut var = Variational::new(sys, JacobianSink::default())?;
    if param.is_some() && var.bar.laws.hertz.is_some() {
        return Err(SimError::Unsupported(VARIATIONAL_NO_HERTZ_PARAM));
    }
    var.bar.param = param;
    let summary = {
        let v: &mut dyn Observer = &mut var;
        solver.run(
            sys,
            init,
            t_end_s,
            &mut crate::solver::Fanout(&mut [v, extra]),
        )?
    };
    var.conclude()?;
    let jacobian = var.sink.jacobian;
    let end_field = var.end_field(t_end_s, &vec_of(&summary.final_state));
    Ok((
        FlowJacobian {
            state: summary.final_state,
            jacobian,
            end_field,
            events: var.counts,
            summary,
        },
        var.bar.dxdp,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn determinant_of_products_and_blocks() {
        let a: Mat4 = [
            [2.0, 1.0, 0.0, 3.0],
            [0.5, -1.0, 2.0, 0.0],
            [1.0, 0.0, 1.0, 1.0],
            [0.0, 2.0, -1.0, 4.0],
        ];
        let b: Mat4 = [
            [1.0, 0.0, 2.0, 0.0],
            [0.0, 3.0, 0.0, 1.0],
            [1.0, 1.0, 1.0, 0.0],
            [0.0, 0.0, 0.5, 2.0],
        ];
        let (da, db) = (det4(&a), det4(&b));
        assert!((det4(&mat_mul(&a, &b)) - da * db).abs() < 1e-12 * (da * db).abs());
        assert!((det4(&IDENTITY) - 1.0).abs() < 1e-15);
    }
}
