//! The bar without ball is linear: `M ü + C u̇ + K u = F_s + F0 sin Ωt` has a closed-form
//! solution, written out independently here (particular + homogeneous part, transient included).
//! rk4 must match it, converge with order 4, and give the right steady-state RMS.

use vibrobar_core::analysis::{RmsObserver, Sampler};
use vibrobar_core::solver::Rk4;
use vibrobar_core::{Bar, Forcing, Frequency, Solver, State, System};

fn bar_system(ratio: f64, static_force_n: f64) -> System {
    System {
        bar: Bar::PAPER_SOLID.into(),
        damper: None,
        forcing: Forcing {
            amplitude_n: 15.0,
            frequency: Frequency::Ratio(ratio),
            static_force_n,
        },
        gravity_m_s2: 9.80665,
    }
}

/// Closed form of the underdamped linear oscillator from `(u0, v0)` at `t = 0`.
struct Exact {
    fs_over_k: f64,
    x: f64,
    phi: f64,
    omega: f64,
    sigma: f64,
    omega_d: f64,
    a: f64,
    b: f64,
}

impl Exact {
    fn new(sys: &System, init: &State) -> Exact {
        let (m, c, k) = (
            sys.lumped_bar().unwrap().mass_kg,
            sys.lumped_bar().unwrap().damping_n_s_per_m(),
            sys.lumped_bar().unwrap().stiffness_n_per_m,
        );
        let (fs, f0, omega) = (
            sys.forcing.static_force_n,
            sys.forcing.amplitude_n,
            sys.omega_rad_s(),
        );
        let (u0, v0) = (init.u_m, init.du_m_s);
        // Particular: u_p = F_s/K + X sin(Ωt − φ), X = F0 / |K − MΩ² + iCΩ|.
        let re = k - m * omega * omega;
        let im = c * omega;
        let x = f0 / re.hypot(im);
        let phi = im.atan2(re);
        // Homogeneous: e^{−σt}(A cos ω_d t + B sin ω_d t), σ = C/(2M), ω_d = √(K/M − σ²).
        let sigma = c / (2.0 * m);
        let omega_d = (k / m - sigma * sigma).sqrt();
        let up0 = fs / k - x * phi.sin();
        let vp0 = x * omega * phi.cos();
        let a = u0 - up0;
        let b = (v0 - vp0 + sigma * a) / omega_d;
        Exact {
            fs_over_k: fs / k,
            x,
            phi,
            omega,
            sigma,
            omega_d,
            a,
            b,
        }
    }
    fn u(&self, t: f64) -> f64 {
        self.fs_over_k
            + self.x * (self.omega * t - self.phi).sin()
            + (-self.sigma * t).exp()
                * (self.a * (self.omega_d * t).cos() + self.b * (self.omega_d * t).sin())
    }
    fn du(&self, t: f64) -> f64 {
        let (c, s) = ((self.omega_d * t).cos(), (self.omega_d * t).sin());
        self.x * self.omega * (self.omega * t - self.phi).cos()
            + (-self.sigma * t).exp()
                * (-self.sigma * (self.a * c + self.b * s)
                    + self.omega_d * (-self.a * s + self.b * c))
    }
}

fn exact_for(sys: &System, init: &State) -> Exact {
    Exact::new(sys, init)
}

#[test]
fn closed_form_satisfies_the_ode_and_initial_conditions() {
    // Guard the closed form itself: residual of M ü + C u̇ + K u − F by central differences.
    let sys = bar_system(0.97, 3.0);
    let init = State {
        u_m: 2e-6,
        du_m_s: -1e-3,
        ..State::REST
    };
    let ex = exact_for(&sys, &init);
    assert!((ex.u(0.0) - 2e-6).abs() < 1e-18 && (ex.du(0.0) + 1e-3).abs() < 1e-15);
    let (m, c, k) = (
        sys.lumped_bar().unwrap().mass_kg,
        sys.lumped_bar().unwrap().damping_n_s_per_m(),
        sys.lumped_bar().unwrap().stiffness_n_per_m,
    );
    let h = 1e-7;
    for t in [1e-3, 0.01, 0.037] {
        let ddu = (ex.du(t + h) - ex.du(t - h)) / (2.0 * h);
        let du_fd = (ex.u(t + h) - ex.u(t - h)) / (2.0 * h);
        let res = m * ddu + c * ex.du(t) + k * ex.u(t) - sys.force_n(t);
        assert!(res.abs() < 1e-5 * 15.0, "ODE residual {res} N at t = {t}");
        assert!(
            (du_fd - ex.du(t)).abs() < 1e-7 * ex.x * ex.omega,
            "u̇ inconsistent with u at t = {t}"
        );
    }
}

/// rk4 at dt = 1 µs against the closed form at several times, from rest and from a non-zero
/// state, at several ratios including resonance.
#[test]
fn rk4_matches_closed_form_with_transient() {
    let inits = [
        State::REST,
        State {
            u_m: 3e-6,
            du_m_s: -2e-3,
            ..State::REST
        },
    ];
    for ratio in [0.5, 0.95, 1.0, 1.05, 2.0] {
        for (fs, init) in [(0.0, inits[0]), (5.0, inits[1])] {
            let sys = bar_system(ratio, fs);
            let ex = exact_for(&sys, &init);
            let mut sampler = Sampler::new(0.0, 5e-3);
            Rk4 { dt_s: 1e-6 }
                .run(&sys, &init, 0.05, &mut sampler)
                .unwrap();
            assert_eq!(sampler.samples.len(), 11);
            let scale = ex.x + ex.fs_over_k.abs();
            let mut worst = 0.0f64;
            for s in &sampler.samples {
                let err = (s.u_m - ex.u(s.t_s)).abs() / scale;
                let err_v = (s.du_m_s - ex.du(s.t_s)).abs() / (scale * ex.omega);
                worst = worst.max(err).max(err_v);
            }
            eprintln!("ratio {ratio} F_s {fs}: worst rel error {worst:.3e}");
            assert!(
                worst < 1e-9,
                "ratio {ratio}, F_s = {fs} N, init {init:?}: worst relative error {worst:.3e} \
                 of the amplitude {scale:.4e} m, want < 1e-9"
            );
        }
    }
}

/// Global order from dt halving, at the end of a 20 ms run (no interpolation involved).
#[test]
fn rk4_global_order_is_four() {
    let sys = bar_system(1.0, 2.0);
    let init = State {
        u_m: 1e-6,
        du_m_s: 1e-3,
        ..State::REST
    };
    let ex = exact_for(&sys, &init);
    let t_end = 0.02;
    let errs: Vec<f64> = [8e-5, 4e-5, 2e-5, 1e-5]
        .iter()
        .map(|&dt| {
            let f = Rk4 { dt_s: dt }
                .run(&sys, &init, t_end, &mut ())
                .unwrap()
                .final_state;
            (f.u_m - ex.u(t_end)).abs()
        })
        .collect();
    eprintln!("rk4 errors at t_end {errs:?}");
    for w in errs.windows(2) {
        let order = (w[0] / w[1]).log2();
        eprintln!("order {order:.4}");
        assert!(
            (3.8..=4.2).contains(&order),
            "errors {errs:?} m at t = {t_end} s: observed order {order:.3}, want 4 ± 0.2"
        );
    }
}

/// Steady-state RMS over whole cycles equals X/√2 of the closed form.
#[test]
fn steady_state_rms_is_amplitude_over_sqrt2() {
    for ratio in [0.95, 1.0, 1.05] {
        let sys = bar_system(ratio, 0.0);
        let ex = exact_for(&sys, &State::REST);
        let t_end = 1.0;
        // Transient e^{−σt}: σ = ζω_n ≈ 37/s, so it is below 1e-8 of X after 0.5 s. Measured: ~4e-10.
        let t_start = t_end - (0.5 / sys.forcing_period_s()).floor() * sys.forcing_period_s();
        let mut rms = RmsObserver::new(t_start, t_end);
        Rk4 { dt_s: 1e-6 }
            .run(&sys, &State::REST, t_end, &mut rms)
            .unwrap();
        let want = ex.x / 2f64.sqrt();
        let rel = (rms.rms_m() / want - 1.0).abs();
        eprintln!("ratio {ratio}: rms rel error {rel:.3e}");
        assert!(
            rel < 1e-8,
            "ratio {ratio}: RMS {} m vs X/√2 = {want} m (rel {rel:.3e})",
            rms.rms_m()
        );
    }
}
