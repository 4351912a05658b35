//! Issue #8 part 1: the structure model against closed forms and independent computations
//! (shared VALIDATION.md, "Uniform clamped–free Euler–Bernoulli bar").

use num_complex::Complex64;
use std::f64::consts::PI;
use vibrobar_core::limits;
use vibrobar_core::structure::analytic::{beta_l, UniformMode};
use vibrobar_core::structure::beam::{default_mode_count, FE_CAVITY_ELEMENTS, FE_FREQ_TOLERANCE};
use vibrobar_core::structure::fe::Mesh;
use vibrobar_core::structure::{
    Beam, CavitySection, DampingRatio, ModalModel, Mode, Point, Structure, TipMass,
};
use vibrobar_core::Bar;

fn rel(a: f64, b: f64) -> f64 {
    (a / b - 1.0).abs()
}

/// Composite Simpson on [a, b] with `n` (even) intervals.
fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let h = (b - a) / n as f64;
    let mut acc = f(a) + f(b);
    for k in 1..n {
        acc += if k % 2 == 1 { 4.0 } else { 2.0 } * f(a + k as f64 * h);
    }
    acc * h / 3.0
}

fn paper_beam() -> Beam {
    Beam::default()
}

/// A uniform mesh of the paper's bar with `ne` elements (FE forced on a uniform bar).
fn uniform_mesh(b: &Beam, ne: usize, tip: Option<TipMass>) -> Mesh {
    let t = tip.unwrap_or(TipMass {
        mass_kg: 0.0,
        rotary_inertia_kg_m2: 0.0,
    });
    Mesh {
        nodes_m: (0..=ne)
            .map(|k| b.length_m * k as f64 / ne as f64)
            .collect(),
        ei_n_m2: vec![b.youngs_modulus_pa * b.second_moment_m4(); ne],
        rho_a_kg_m: vec![b.density_kg_m3 * b.area_m2(); ne],
        tip_mass_kg: t.mass_kg,
        tip_inertia_kg_m2: t.rotary_inertia_kg_m2,
        hole: None,
    }
}

#[test]
fn analytic_frequencies_are_beta_l_squared_times_the_bar_constant() {
    let b = Beam {
        modes: Some(5),
        ..paper_beam()
    };
    let m = b.modal_model().unwrap();
    let c = (b.youngs_modulus_pa * b.second_moment_m4() / (b.density_kg_m3 * b.area_m2())).sqrt()
        / b.length_m.powi(2);
    for (k, want) in [
        1.875_104_069,
        4.694_091_133,
        7.854_757_438,
        10.995_540_735,
        14.137_168_391,
    ]
    .iter()
    .enumerate()
    {
        assert!((beta_l(k + 1) - want).abs() < 1e-9);
        let bl = (m.modes()[k].omega_rad_s / c).sqrt();
        assert!((bl - want).abs() < 1e-9, "mode {}: βL = {bl}", k + 1);
    }
    // Paper bar: f₁ = 576.5 Hz (ω₁ = 3622 rad/s, as `vibrobar beam` says).
    let f1 = m.modes()[0].omega_rad_s / (2.0 * PI);
    assert!((f1 - 576.5).abs() < 0.1, "f₁ = {f1}");
    assert!(
        rel(
            m.modes()[0].omega_rad_s,
            vibrobar_core::euler_bernoulli::BeamGeometry::PAPER_SOLID.omega1_uniform_rad_s()
        ) < 1e-14
    );
}

#[test]
fn mode1_shape_at_tabulated_points() {
    let m = UniformMode::new(1);
    for (xi, want) in [(0.5, 0.3395), (0.7, 0.5909), (0.8, 0.7255), (0.9, 0.8624)] {
        assert!(
            (m.shape(xi) - want).abs() < 5e-5,
            "φ₁({xi}) = {}",
            m.shape(xi)
        );
        // The textbook form (fine for mode 1) agrees.
        let b = beta_l(1);
        let s = (b.cosh() + b.cos()) / (b.sinh() + b.sin());
        let tb = |x: f64| (b * x).cosh() - (b * x).cos() - s * ((b * x).sinh() - (b * x).sin());
        assert!((m.shape(xi) - tb(xi) / tb(1.0)).abs() < 1e-13);
    }
    assert!(m.shape(0.0).abs() < 1e-15);
    assert!((m.shape(1.0) - 1.0).abs() < 1e-15);
}

#[test]
fn modal_mass_is_a_quarter_of_the_bar_mass_in_tip_normalisation() {
    let b = Beam {
        modes: Some(30),
        ..paper_beam()
    };
    let m = b.modal_model().unwrap();
    let ra = b.density_kg_m3 * b.area_m2();
    for n in [1usize, 2, 3, 5, 8, 30] {
        let u = UniformMode::new(n);
        let q = simpson(|x| u.shape(x).powi(2), 0.0, 1.0, 40_000) * ra * b.length_m;
        assert!(rel(q, 0.25 * b.mass_kg()) < 1e-9, "mode {n}: ∫ρAφ² = {q}");
        assert!(rel(m.modes()[n - 1].modal_mass_kg, q) < 1e-9);
    }
}

#[test]
fn high_modes_stay_finite_and_orthogonal() {
    let modes: Vec<UniformMode> = [1usize, 2, 10, 29, 30, 31]
        .iter()
        .map(|&n| UniformMode::new(n))
        .collect();
    for u in &modes {
        for k in 0..=1000 {
            let v = u.shape(k as f64 / 1000.0);
            assert!(v.is_finite() && v.abs() < 3.0, "βL = {}: {v}", u.beta_l);
        }
    }
    let n = 40_000;
    for (i, a) in modes.iter().enumerate() {
        for b in &modes[i + 1..] {
            let ab = simpson(|x| a.shape(x) * b.shape(x), 0.0, 1.0, n);
            assert!(
                ab.abs() < 1e-9,
                "∫φφ = {ab} (βL {} and {})",
                a.beta_l,
                b.beta_l
            );
        }
    }
    // The textbook form has lost every digit at n = 30: that is why the e^{−βx} form exists.
    let b = beta_l(30);
    let s = (b.cosh() + b.cos()) / (b.sinh() + b.sin());
    let tb = |x: f64| (b * x).cosh() - (b * x).cos() - s * ((b * x).sinh() - (b * x).sin());
    assert!((tb(1.0).abs() - 2.0).abs() > 1e-3, "textbook {}", tb(1.0));
    assert!((UniformMode::new(30).raw(1.0).abs() - 2.0).abs() < 1e-12);
    // FE modes of 30 modes' mesh: mass-orthogonal, stiffness-orthogonal.
    let beam = Beam {
        modes: Some(30),
        tip_mass: Some(TipMass {
            mass_kg: 0.01,
            rotary_inertia_kg_m2: 0.0,
        }),
        ..paper_beam()
    };
    let mesh = beam.mesh(30).unwrap();
    let fe = mesh.modes(30).unwrap();
    let (_, mm) = mesh.matrices();
    let vec_of = |k: usize| {
        let mut v = Vec::new();
        for node in 1..mesh.nodes_m.len() {
            v.push(fe.deflection[k][node]);
            v.push(fe.slope[k][node]);
        }
        nalgebra::DVector::from_vec(v)
    };
    let v: Vec<_> = (0..30).map(vec_of).collect();
    for i in [0usize, 5, 28] {
        for j in [1usize, 17, 29] {
            if i == j {
                continue;
            }
            let mij = (v[i].transpose() * &mm * &v[j])[(0, 0)];
            let norm = (fe.modal_mass_kg[i] * fe.modal_mass_kg[j]).sqrt();
            assert!(mij.abs() < 1e-9 * norm, "φ{i}ᵀMφ{j} = {mij}");
        }
    }
    assert!(fe.omega_rad_s.iter().all(|w| w.is_finite() && *w > 0.0));
}

/// Observed order of the FE eigenvalues and the error constant of the mesh rule.
#[test]
fn fe_frequencies_converge_to_the_closed_form_at_order_four() {
    let b = paper_beam();
    let exact = b.clone().with_modes(4).modal_model().unwrap();
    let errs: Vec<Vec<f64>> = [8usize, 16, 32]
        .iter()
        .map(|&ne| {
            let fe = uniform_mesh(&b, ne, None).modes(4).unwrap();
            (0..4)
                .map(|k| fe.omega_rad_s[k] / exact.modes()[k].omega_rad_s - 1.0)
                .collect()
        })
        .collect();
    for k in 0..4 {
        for w in errs.windows(2) {
            assert!(
                w[0][k] > 0.0 && w[1][k] > 0.0,
                "FE frequencies are upper bounds"
            );
            let order = (w[0][k] / w[1][k]).log2();
            println!("mode {}: observed order {order:.3}", k + 1);
            assert!(
                (3.85..4.15).contains(&order),
                "mode {}: order {order}",
                k + 1
            );
        }
        // Error constant of the mesh rule: δω/ω ≈ (βh)⁴/1440 (within 5 % at 32 elements).
        let bh = beta_l(k + 1) / 32.0;
        let c = errs[2][k] / bh.powi(4);
        assert!(
            rel(c, 1.0 / 1440.0) < 0.05,
            "mode {}: constant 1/{}",
            k + 1,
            1.0 / c
        );
    }
}

#[test]
fn mesh_rule_meets_its_tolerance() {
    // A tiny tip mass forces the FE path; its effect on the frequencies (ratio 1e-9) is far below
    // the tolerance, so the closed form is the reference.
    for n in [3usize, 8, 16] {
        let b = Beam {
            modes: Some(n),
            tip_mass: Some(TipMass {
                mass_kg: 1e-9 * paper_beam().mass_kg(),
                rotary_inertia_kg_m2: 0.0,
            }),
            ..paper_beam()
        };
        let fe = b.modal_model().unwrap();
        let an = paper_beam().with_modes(n).modal_model().unwrap();
        for k in 0..n {
            let e = rel(fe.modes()[k].omega_rad_s, an.modes()[k].omega_rad_s);
            assert!(e < FE_FREQ_TOLERANCE, "N = {n}, mode {}: {e:e}", k + 1);
            for p in [Point::Cavity, Point::Force, Point::Response] {
                let (a, f) = (an.modes()[k].shape(p), fe.modes()[k].shape(p));
                assert!(
                    (a - f).abs() < 1e-5,
                    "N = {n}, mode {}: {p:?} {a} vs {f}",
                    k + 1
                );
            }
            assert!(rel(fe.modes()[k].modal_mass_kg, an.modes()[k].modal_mass_kg) < 1e-5);
        }
    }
}

#[test]
fn static_tip_compliance_from_the_modal_sum_and_from_fe() {
    let b = paper_beam();
    let ei = b.youngs_modulus_pa * b.second_moment_m4();
    let c0 = b.length_m.powi(3) / (3.0 * ei);
    let m = b.clone().with_modes(32).modal_model().unwrap();
    assert!(rel(m.static_tip_compliance_m_per_n, c0) < 1e-15);
    for (n, pct) in [(1, 97.07), (2, 99.54), (3, 99.86), (4, 99.94)] {
        let got = 100.0 * m.tip_compliance_of_first(n) / c0;
        assert!((got - pct).abs() < 0.005, "N = {n}: {got} %");
    }
    // Σ 12/(βₙL)⁴ → 1: 32 modes leave about 4/(3π⁴·32³)·… < 1e-5.
    assert!((m.captured_static_fraction() - 1.0).abs() < 1e-5);
    // FE: nodally exact for a static tip load, whatever the mesh.
    for ne in [1usize, 3, 24] {
        let fe = uniform_mesh(&b, ne, None).modes(1).unwrap();
        assert!(
            rel(fe.static_tip_compliance_m_per_n, c0) < 1e-10,
            "ne = {ne}"
        );
    }
    // Default N: 3 for the uniform bar (99.86 % ≥ 99.5 %, and at least 3).
    let d = b.modal_model().unwrap();
    assert_eq!(d.len(), 3);
    assert_eq!(default_mode_count(&m), Some(3));
}

/// Tip receptance of the undamped continuous cantilever in closed form (dynamic stiffness of the
/// beam equation): `G = (sin βL cosh βL − cos βL sinh βL) / (EIβ³ (1 + cos βL cosh βL))`,
/// `β⁴ = ρAω²/EI`; statically `L³/3EI`.
fn closed_form_tip_receptance(b: &Beam, omega: f64) -> f64 {
    let ei = b.youngs_modulus_pa * b.second_moment_m4();
    let beta = (b.density_kg_m3 * b.area_m2() * omega * omega / ei).powf(0.25);
    let x = beta * b.length_m;
    (x.sin() * x.cosh() - x.cos() * x.sinh()) / (ei * beta.powi(3) * (1.0 + x.cos() * x.cosh()))
}

#[test]
fn tip_frf_against_the_closed_form_and_fe() {
    let b = Beam {
        damping_ratio: DampingRatio::All(0.0),
        ..paper_beam()
    };
    let m = b.clone().with_modes(32).modal_model().unwrap();
    let w1 = m.modes()[0].omega_rad_s;
    // The truncated modes respond quasi-statically: their static share (residual flexibility)
    // is what the 32-mode sum misses, 6e-13 m/N.
    let residual = m.static_tip_compliance_m_per_n
        - m.static_compliance_m_per_n(Point::Force, Point::Response);
    assert!(residual > 0.0 && residual < 2e-6 * m.static_tip_compliance_m_per_n);
    for r in [0.3, 0.8, 1.3, 3.5, 10.0, 20.0] {
        let w = r * w1;
        let g = m.receptance(Point::Force, Point::Response, w);
        let want = closed_form_tip_receptance(&b, w);
        assert!(g.im.abs() < 1e-30);
        assert!(
            (g.re - want).abs() < 1.5 * residual,
            "Ω/ω₁ = {r}: {} vs {want}",
            g.re
        );
        assert!(
            rel(g.re + residual, want) < 1e-7,
            "Ω/ω₁ = {r}: {} vs {want}",
            g.re + residual
        );
    }
    // Damped: the modal sum with ζ against FE modes (same ζ), receptance between two points.
    let b = Beam {
        force_position_m: Some(0.16),
        response_position_m: Some(0.1),
        modes: Some(6),
        ..paper_beam()
    };
    let an = b.modal_model().unwrap();
    let fe = Beam {
        tip_mass: Some(TipMass {
            mass_kg: 1e-12,
            rotary_inertia_kg_m2: 0.0,
        }),
        ..b.clone()
    }
    .modal_model()
    .unwrap();
    for r in [0.5, 0.99, 1.0, 2.0, 6.27] {
        let w = r * an.modes()[0].omega_rad_s;
        let (ga, gf) = (
            an.receptance(Point::Force, Point::Response, w),
            fe.receptance(Point::Force, Point::Response, w),
        );
        assert!(
            (ga - gf).norm() < 1e-5 * ga.norm(),
            "Ω/ω₁ = {r}: {ga} vs {gf}"
        );
        // Reciprocity.
        let back = an.receptance(Point::Response, Point::Force, w);
        assert!((back - ga).norm() <= 1e-15 * ga.norm());
    }
    // At resonance the first mode's term is −i/(2ζ k₁).
    let g = an.receptance(Point::Response, Point::Response, an.modes()[0].omega_rad_s);
    let m1 = an.modes()[0];
    let peak = Complex64::new(0.0, -1.0) * m1.shape_response.powi(2)
        / (2.0 * m1.damping_ratio * m1.modal_stiffness_n_per_m());
    assert!((g - peak).norm() < 0.02 * peak.norm());
}

/// `1 + cos x cosh x + μ x (cos x sinh x − sin x cosh x) = 0`, `μ = m_t/ρAL`, divided by
/// `cosh x` (bounded terms), roots by scanning and bisection.
fn tip_mass_roots(mu: f64, count: usize) -> Vec<f64> {
    let f = |x: f64| 1.0 / x.cosh() + x.cos() + mu * x * (x.cos() * x.tanh() - x.sin());
    let mut roots = Vec::new();
    let (mut x, dx) = (1e-3, 1e-3);
    while roots.len() < count {
        if f(x) * f(x + dx) < 0.0 {
            let (mut lo, mut hi) = (x, x + dx);
            for _ in 0..100 {
                let mid = 0.5 * (lo + hi);
                if f(lo) * f(mid) <= 0.0 {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            roots.push(0.5 * (lo + hi));
        }
        x += dx;
    }
    roots
}

#[test]
fn tip_mass_against_the_closed_form_frequency_equation() {
    // Sign check of the equation, independently: a huge tip mass makes the bar a spring 3EI/L³
    // under m_t, ω² = 3EI/(m_t L³), i.e. (βL)⁴ = 3/μ.
    let mu = 1e4;
    let x = tip_mass_roots(mu, 1)[0];
    assert!(
        rel(x.powi(4), 3.0 / mu) < 1e-3,
        "(βL)⁴ μ = {}",
        x.powi(4) * mu
    );
    // μ = 0 gives the bare cantilever.
    assert!((tip_mass_roots(0.0, 1)[0] - beta_l(1)).abs() < 1e-9);
    let b = paper_beam();
    let c = (b.youngs_modulus_pa * b.second_moment_m4() / (b.density_kg_m3 * b.area_m2())).sqrt()
        / b.length_m.powi(2);
    for mu in [0.1, 0.5, 2.0] {
        let beam = Beam {
            modes: Some(5),
            tip_mass: Some(TipMass {
                mass_kg: mu * b.mass_kg(),
                rotary_inertia_kg_m2: 0.0,
            }),
            ..b.clone()
        };
        let m = beam.modal_model().unwrap();
        for (k, x) in tip_mass_roots(mu, 5).iter().enumerate() {
            let want = x * x * c;
            let e = rel(m.modes()[k].omega_rad_s, want);
            assert!(e < FE_FREQ_TOLERANCE, "μ = {mu}, mode {}: {e:e}", k + 1);
        }
        // Tip-normalised, the tip mass adds itself to the modal mass; the bar's share moves from
        // ρAL/4 (free mode shape) towards 33/140 ρAL (static shape) as the tip mass grows.
        let bar_share = (m.modes()[0].modal_mass_kg - mu * b.mass_kg()) / b.mass_kg();
        assert!(
            (33.0 / 140.0..0.25).contains(&bar_share),
            "μ = {mu}: bar share {bar_share}"
        );
    }
    // Rotary inertia lowers every frequency further.
    let with = |j: f64| {
        Beam {
            modes: Some(3),
            tip_mass: Some(TipMass {
                mass_kg: 0.1,
                rotary_inertia_kg_m2: j,
            }),
            ..b.clone()
        }
        .modal_model()
        .unwrap()
    };
    let (a, bj) = (with(0.0), with(1e-4));
    for k in 0..3 {
        assert!(bj.modes()[k].omega_rad_s < a.modes()[k].omega_rad_s);
    }
}

#[test]
fn lumped_structure_reproduces_the_bar_exactly() {
    for bar in [Bar::PAPER_CAVITY, Bar::PAPER_SOLID] {
        let m = Structure::Lumped(bar).modal_model().unwrap();
        assert_eq!(m.len(), 1);
        let mode = m.modes()[0];
        assert_eq!(
            mode.omega_rad_s.to_bits(),
            bar.natural_freq_rad_s().to_bits()
        );
        assert_eq!(mode.modal_mass_kg.to_bits(), bar.mass_kg.to_bits());
        assert_eq!(mode.damping_ratio.to_bits(), bar.damping_ratio.to_bits());
        for p in [Point::Cavity, Point::Force, Point::Response] {
            assert_eq!(mode.shape(p).to_bits(), 1.0f64.to_bits());
        }
        // Modal stiffness is K to rounding; receptance is 1/(K − MΩ² + iCΩ).
        assert!(rel(mode.modal_stiffness_n_per_m(), bar.stiffness_n_per_m) < 1e-15);
        for r in [0.5, 1.0, 1.7] {
            let w = r * bar.natural_freq_rad_s();
            let want = 1.0
                / Complex64::new(
                    bar.stiffness_n_per_m - bar.mass_kg * w * w,
                    bar.damping_n_s_per_m() * w,
                );
            let g = m.receptance(Point::Force, Point::Response, w);
            // `want` carries the rounding of K − MΩ² (≈ 1e-20 at resonance, where it is 0).
            assert!((g - want).norm() < 1e-12 * want.norm(), "{g} vs {want}");
        }
        assert_eq!(m.static_tip_compliance_m_per_n, 1.0 / bar.stiffness_n_per_m);
        assert!((m.captured_static_fraction() - 1.0).abs() < 1e-15);
    }
}

#[test]
fn measured_modes_are_taken_as_given() {
    let modes = vec![
        Mode {
            omega_rad_s: 2e4,
            damping_ratio: 0.02,
            modal_mass_kg: 0.2,
            shape_cavity: -0.5,
            shape_force: 1.0,
            shape_response: 1.0,
        },
        Mode {
            omega_rad_s: 3.6e3,
            damping_ratio: 0.01,
            modal_mass_kg: 0.17,
            shape_cavity: 0.7,
            shape_force: 1.0,
            shape_response: 1.0,
        },
    ];
    let m = Structure::Measured(modes.clone()).modal_model().unwrap();
    assert_eq!(m.modes(), &[modes[1], modes[0]], "sorted by frequency");
    assert!((m.captured_static_fraction() - 1.0).abs() < 1e-15);
    let mut bad = modes.clone();
    bad[0].modal_mass_kg = 0.0;
    let e = Structure::Measured(bad).modal_model().unwrap_err();
    assert_eq!(e.field(), "modes.modal_mass_kg");
    let e = Structure::Measured(vec![]).modal_model().unwrap_err();
    assert!(e.to_string().contains("[1, 32]"), "{e}");
}

#[test]
fn paper_geometry_cavity_38_mm_from_the_free_end() {
    let b = paper_beam();
    assert!((b.length_m - b.cavity_position_m - 0.038).abs() < 1e-15);
    let m = b.modal_model().unwrap();
    let phi = m.modes()[0].shape_cavity;
    assert!((0.69..0.71).contains(&phi), "φ₁(cavity) = {phi}");
    // The cavity section: FE tip compliance against the unit-load integral of euler_bernoulli.
    let sec = Beam {
        cavity_section: Some(CavitySection {
            hole_diameter_m: 0.0151,
            length_m: 0.017,
        }),
        ..b.clone()
    };
    let ms = sec.modal_model().unwrap();
    let ratio =
        vibrobar_core::euler_bernoulli::BeamGeometry::paper_cavity().cavity_stiffness_ratio();
    let got = m.static_tip_compliance_m_per_n / ms.static_tip_compliance_m_per_n;
    assert!(
        (got - ratio).abs() < 1e-6,
        "stiffness ratio FE {got} vs unit load {ratio}"
    );
    // Mass: the elements inside the hole lose exactly ρ·π d_h²/4·ℓ.
    let mass = sec.mesh(3).unwrap().mass_kg();
    let hole = b.density_kg_m3 * PI * 0.0151f64.powi(2) / 4.0 * 0.017;
    assert!(
        rel(b.mass_kg() - mass, hole) < 1e-9,
        "Δm = {}",
        b.mass_kg() - mass
    );
    // The lost mass near the tip outweighs the lost stiffness: f₁ goes up, as in the paper.
    assert!(ms.modes()[0].omega_rad_s > m.modes()[0].omega_rad_s);
    let shift = ms.modes()[0].omega_rad_s / m.modes()[0].omega_rad_s - 1.0;
    println!(
        "paper bar: f₁ {:.2} Hz solid, {:.2} Hz with cavity section ({:+.3} %)",
        m.modes()[0].omega_rad_s / (2.0 * PI),
        ms.modes()[0].omega_rad_s / (2.0 * PI),
        100.0 * shift
    );
    assert!(shift < 0.05, "shift {shift}");
    assert!(ms.captured_static_fraction() >= 0.995 && ms.len() >= 3);
}

#[test]
fn bad_input_names_the_field_and_its_range() {
    let ok = paper_beam();
    let field = |b: Beam| b.modal_model().unwrap_err().field();
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert_eq!(
            field(Beam {
                length_m: bad,
                ..ok.clone()
            }),
            "beam.length_m"
        );
        assert_eq!(
            field(Beam {
                diameter_m: bad,
                ..ok.clone()
            }),
            "beam.diameter_m"
        );
        assert_eq!(
            field(Beam {
                youngs_modulus_pa: bad,
                ..ok.clone()
            }),
            "beam.youngs_modulus_pa"
        );
        assert_eq!(
            field(Beam {
                density_kg_m3: bad,
                ..ok.clone()
            }),
            "beam.density_kg_m3"
        );
    }
    for x in [-1e-3, 0.176, f64::NAN] {
        let e = Beam {
            cavity_position_m: x,
            ..ok.clone()
        }
        .modal_model()
        .unwrap_err();
        assert_eq!(e.field(), "beam.cavity_position_m (--cavity-position-mm)");
        if x.is_finite() {
            assert!(e.to_string().contains("[0, 0.175]"), "{e}");
        }
        assert_eq!(
            field(Beam {
                force_position_m: Some(x),
                ..ok.clone()
            }),
            "beam.force_position_m"
        );
        assert_eq!(
            field(Beam {
                response_position_m: Some(x),
                ..ok.clone()
            }),
            "beam.response_position_m"
        );
    }
    // The ends are allowed.
    for x in [0.0, 0.175] {
        Beam {
            cavity_position_m: x,
            force_position_m: Some(x),
            response_position_m: Some(x),
            ..ok.clone()
        }
        .modal_model()
        .unwrap();
    }
    for n in [0usize, limits::MAX_BEAM_MODES + 1, usize::MAX] {
        let e = Beam {
            modes: Some(n),
            ..ok.clone()
        }
        .modal_model()
        .unwrap_err();
        assert_eq!(e.field(), "beam.modes (--beam-modes)");
        assert!(e.to_string().contains("[1, 32]"), "{e}");
    }
    let sec = |d: f64, l: f64, x: f64| Beam {
        cavity_position_m: x,
        cavity_section: Some(CavitySection {
            hole_diameter_m: d,
            length_m: l,
        }),
        ..ok.clone()
    };
    // Hole wider than the bar's section, or than the bar is long.
    assert_eq!(
        field(sec(0.026, 0.01, 0.1)),
        "beam.cavity_section.hole_diameter_m"
    );
    assert_eq!(
        field(sec(0.025, 0.01, 0.1)),
        "beam.cavity_section.hole_diameter_m"
    );
    let short = Beam {
        length_m: 0.01,
        ..sec(0.015, 0.01, 0.005)
    };
    assert_eq!(field(short), "beam.cavity_section.hole_diameter_m");
    // Cavity longer (across the bar) than the section holds.
    let e = sec(0.0151, 0.024, 0.1).modal_model().unwrap_err();
    assert_eq!(e.field(), "beam.cavity_section.length_m");
    assert!(e.to_string().contains("inside the bar"), "{e}");
    for bad in [0.0, -1.0, f64::NAN] {
        assert_eq!(
            field(sec(bad, 0.01, 0.1)),
            "beam.cavity_section.hole_diameter_m"
        );
        assert_eq!(field(sec(0.01, bad, 0.1)), "beam.cavity_section.length_m");
    }
    // The hole sticks out of the bar's end.
    let e = sec(0.0151, 0.017, 0.17).modal_model().unwrap_err();
    assert_eq!(e.field(), "beam.cavity_position_m (--cavity-position-mm)");
    // Damping, tip mass, mesh.
    for z in [-0.1, 1.0, f64::NAN] {
        assert_eq!(
            field(Beam {
                damping_ratio: DampingRatio::All(z),
                ..ok.clone()
            }),
            "beam.damping_ratio"
        );
        assert_eq!(
            field(Beam {
                damping_ratio: DampingRatio::PerMode(vec![0.01, z]),
                ..ok.clone()
            }),
            "beam.damping_ratio"
        );
    }
    assert_eq!(
        field(Beam {
            damping_ratio: DampingRatio::PerMode(vec![]),
            ..ok.clone()
        }),
        "beam.damping_ratio (list length)"
    );
    for (m, j, f) in [
        (-1.0, 0.0, "beam.tip_mass.mass_kg"),
        (1e6, 0.0, "beam.tip_mass.mass_kg"),
        (0.1, -1.0, "beam.tip_mass.rotary_inertia_kg_m2"),
        (0.1, f64::INFINITY, "beam.tip_mass.rotary_inertia_kg_m2"),
    ] {
        assert_eq!(
            field(Beam {
                tip_mass: Some(TipMass {
                    mass_kg: m,
                    rotary_inertia_kg_m2: j
                }),
                ..ok.clone()
            }),
            f
        );
    }
    for n in [0usize, 5, limits::MAX_FE_ELEMENTS + 1] {
        assert_eq!(
            field(Beam {
                fe_elements: Some(n),
                ..ok.clone()
            }),
            "beam.fe_elements"
        );
    }
}

#[test]
fn per_mode_damping_and_its_last_value_beyond_the_list() {
    let b = Beam {
        modes: Some(4),
        damping_ratio: DampingRatio::PerMode(vec![0.01, 0.02]),
        ..paper_beam()
    };
    let z: Vec<f64> = b
        .modal_model()
        .unwrap()
        .modes()
        .iter()
        .map(|m| m.damping_ratio)
        .collect();
    assert_eq!(z, vec![0.01, 0.02, 0.02, 0.02]);
}

#[test]
fn every_corner_of_the_allowed_box_gives_finite_modes() {
    let (l, d, e, rho) = (
        limits::BEAM_LENGTH_M,
        limits::BEAM_DIAMETER_M,
        limits::BEAM_YOUNGS_MODULUS_PA,
        limits::BEAM_DENSITY_KG_M3,
    );
    for ll in [l.0, l.1] {
        for dd in [d.0, d.1] {
            for ee in [e.0, e.1] {
                for rr in [rho.0, rho.1] {
                    for tip in [None, Some(0.5)] {
                        let mut b = Beam {
                            length_m: ll,
                            diameter_m: dd,
                            youngs_modulus_pa: ee,
                            density_kg_m3: rr,
                            cavity_position_m: 0.5 * ll,
                            modes: Some(4),
                            ..paper_beam()
                        };
                        b.tip_mass = tip.map(|mu| TipMass {
                            mass_kg: mu * b.mass_kg(),
                            rotary_inertia_kg_m2: 0.0,
                        });
                        let m: ModalModel = b.modal_model().unwrap();
                        assert!(m.modes().iter().all(|m| m.omega_rad_s.is_finite()
                            && m.modal_mass_kg.is_finite()
                            && m.modal_mass_kg > 0.0));
                        assert!(m.static_tip_compliance_m_per_n.is_finite());
                    }
                }
            }
        }
    }
}

/// The mesh rule also converges the non-uniform bar (cavity section and tip mass): against a
/// reference mesh with twice the base elements and twice the elements across the hole.
#[test]
fn mesh_rule_converges_the_cavity_section_and_tip_mass() {
    for n in [3usize, 8] {
        let b = Beam {
            modes: Some(n),
            cavity_section: Some(CavitySection {
                hole_diameter_m: 0.0151,
                length_m: 0.017,
            }),
            tip_mass: Some(TipMass {
                mass_kg: 0.05,
                rotary_inertia_kg_m2: 1e-6,
            }),
            ..paper_beam()
        };
        let rule = b.modal_model().unwrap();
        let reference = b
            .mesh_with(2 * b.fe_element_target(n), 2 * FE_CAVITY_ELEMENTS)
            .unwrap()
            .modes(n)
            .unwrap();
        for k in 0..n {
            let e = rel(rule.modes()[k].omega_rad_s, reference.omega_rad_s[k]);
            println!("N = {n}, mode {}: rule vs reference {e:.2e}", k + 1);
            assert!(e < FE_FREQ_TOLERANCE, "N = {n}, mode {}: {e:e}", k + 1);
        }
    }
}

/// `fe_elements = MAX_FE_ELEMENTS` passed validation, then the mesh, grown by the splits at the
/// cavity ends and the points, was refused at 601 elements.
#[test]
fn regression_fe_elements_at_its_limit_is_not_refused_by_the_mesh() {
    let b = Beam {
        modes: Some(3),
        fe_elements: Some(limits::MAX_FE_ELEMENTS),
        force_position_m: Some(0.17),
        response_position_m: Some(0.1),
        cavity_section: Some(CavitySection {
            hole_diameter_m: 0.0151,
            length_m: 0.017,
        }),
        ..paper_beam()
    };
    let m = b.modal_model().unwrap();
    assert!(b.mesh(3).unwrap().elements() > limits::MAX_FE_ELEMENTS);
    assert_eq!(m.len(), 3);
}
