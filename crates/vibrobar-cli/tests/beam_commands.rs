//! Issue #8 §5–6: every command accepts a `[beam]` scenario. The damped bar is the beam's modes
//! with the ball at the cavity; the solid reference is the same bar without the cavity section
//! and without the ball (its own ω₁); `rms_*` are at the response point; the columns are the
//! lumped ones; `--beam-modes` and `--cavity-position-mm` work on every command that takes a
//! system; bad input names the field and its range and writes nothing.

mod common;

use common::{assert_fails_with, assert_ok, vibrobar_in};
use std::fs;
use std::path::Path;
use vibrobar_core::structure::{Beam, CavitySection, DampingRatio, ModalModel, Point};

/// A short, fast beam case: the paper's bar, 2 modes, rk4 at 2 µs for 20 ms.
const FAST: &str = "[beam]\nmodes = 2\ncavity_position_m = 0.137\n\
    [run]\nsolver = \"rk4\"\nduration_s = 0.02\ndt_s = 2e-6\n";

fn header(p: &Path) -> String {
    fs::read_to_string(p)
        .unwrap()
        .lines()
        .next()
        .unwrap()
        .to_string()
}

fn rows(p: &Path) -> Vec<Vec<String>> {
    fs::read_to_string(p)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

fn meta(p: &Path) -> serde_json::Value {
    let m = format!("{}.meta.json", p.display());
    serde_json::from_str(&fs::read_to_string(m).unwrap()).unwrap()
}

/// Each simulating command runs the beam and writes its documented columns (the lumped ones);
/// `lyapunov` estimates it on the modal states.
#[test]
fn every_command_runs_a_beam_scenario() {
    let d = tempfile::tempdir().unwrap();
    fs::write(d.path().join("b.toml"), FAST).unwrap();
    let sc = ["--scenario", "b.toml"];
    let run = |args: &[&str]| {
        let mut a: Vec<&str> = args.to_vec();
        a.extend_from_slice(&sc);
        let o = vibrobar_in(d.path(), &a);
        assert_ok(&o);
        o
    };
    use vibrobar_io::csv::*;
    run(&["run", "--out", "r.csv"]);
    assert_eq!(header(&d.path().join("r.csv")), history_schema().header());
    assert_eq!(rows(&d.path().join("r.csv")).len(), 1001);
    // The metadata records the modal system that ran.
    let m = meta(&d.path().join("r.csv"));
    assert_eq!(
        m["parameters"]["system"]["bar"]["modes"]
            .as_array()
            .unwrap()
            .len(),
        2
    );
    let o = run(&["run", "--out", "e.csv", "--energy"]);
    let e: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let (input, residual) = (
        e["work_input_j"].as_f64().unwrap(),
        e["residual_j"].as_f64().unwrap(),
    );
    assert!(input > 0.0 && residual.abs() < 1e-4 * input, "{e}");

    run(&[
        "sweep",
        "--ratios",
        "0.9:1.1:0.1",
        "--gap-mm",
        "0.1",
        "--out",
        "s.csv",
    ]);
    assert_eq!(header(&d.path().join("s.csv")), sweep_schema().header());
    let s = rows(&d.path().join("s.csv"));
    assert_eq!(s.len(), 3);
    // At resonance the ball hits and the tip's RMS falls.
    assert!(s[1][7].parse::<u64>().unwrap() > 0, "{s:?}");
    assert!(s[1][5].parse::<f64>().unwrap() < s[1][4].parse::<f64>().unwrap());

    run(&[
        "map",
        "--ratios",
        "0.95:1.05:0.05",
        "--gaps-mm",
        "0.1:0.2:0.1",
        "--out",
        "m.csv",
    ]);
    assert_eq!(header(&d.path().join("m.csv")), map_schema(&[]).header());
    assert_eq!(rows(&d.path().join("m.csv")).len(), 6);

    run(&[
        "poincare",
        "--ratio",
        "1",
        "--gap-mm",
        "0.1",
        "--transient",
        "0.005",
        "--out",
        "p.csv",
    ]);
    assert_eq!(header(&d.path().join("p.csv")), poincare_schema().header());
    assert!(!rows(&d.path().join("p.csv")).is_empty());

    run(&[
        "bifurcation",
        "--param",
        "ratio",
        "--values",
        "0.95:1.05:0.05",
        "--gap-mm",
        "0.1",
        "--transient",
        "0.005",
        "--out",
        "bf.csv",
    ]);
    assert_eq!(
        header(&d.path().join("bf.csv")),
        bifurcation_schema("ratio").header()
    );

    run(&[
        "ensemble",
        "--ratio",
        "1",
        "--gap-mm",
        "0.1",
        "--members",
        "3",
        "--out",
        "en.csv",
    ]);
    assert_eq!(header(&d.path().join("en.csv")), ensemble_schema().header());
    assert_eq!(rows(&d.path().join("en.csv"))[0][2], "3");

    let o = run(&[
        "lyapunov",
        "--ratio",
        "1",
        "--gap-mm",
        "0.1",
        "--duration",
        "0.05",
        "--periods",
        "2",
        "--json",
    ]);
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(j["exponent_per_s"].as_f64().unwrap().is_finite(), "{j}");
    assert!(j["intervals"].as_u64().unwrap() >= 2, "{j}");
}

/// The steady RMS over `[a, b]` of `|G| F0 sin(Ωt + arg G)`, in closed form.
fn steady_rms((g_abs, g_arg): (f64, f64), f0: f64, omega: f64, a: f64, b: f64) -> f64 {
    let int = |t: f64| t / 2.0 - (2.0 * (omega * t + g_arg)).sin() / (4.0 * omega);
    g_abs * f0 * ((int(b) - int(a)) / (b - a)).sqrt()
}

/// The solid reference is the same beam without the cavity section and without the ball: its
/// ω₁ is the uniform bar's closed form (the bar with the hole has another), a ratio is Ω/ω₁ of
/// each bar, and its `rms_solid_m`, read at the response point (120 mm from the clamp), is the
/// modal receptance's steady RMS there.
#[test]
fn solid_reference_is_the_beam_without_the_cavity_and_rms_is_at_the_response_point() {
    let d = tempfile::tempdir().unwrap();
    let text = "[beam]\nmodes = 3\ndamping_ratio = 0.05\ncavity_position_m = 0.137\n\
        response_position_m = 0.12\n\
        [beam.cavity_section]\nhole_diameter_m = 0.016\nlength_m = 0.0161\n\
        [run]\nsolver = \"rk4\"\nduration_s = 0.15\nrms_fraction = 0.4\n";
    fs::write(d.path().join("b.toml"), text).unwrap();
    assert_ok(&vibrobar_in(
        d.path(),
        &[
            "sweep",
            "--scenario",
            "b.toml",
            "--ratios",
            "0.9:1.0:0.1",
            "--gap-mm",
            "0.1",
            "--out",
            "s.csv",
        ],
    ));
    let beam = Beam {
        modes: Some(3),
        damping_ratio: DampingRatio::All(0.05),
        cavity_position_m: 0.137,
        response_position_m: Some(0.12),
        cavity_section: Some(CavitySection {
            hole_diameter_m: 0.016,
            length_m: 0.0161,
        }),
        ..Beam::default()
    };
    let damped: ModalModel = beam.modal_model().unwrap();
    let solid: ModalModel = Beam {
        cavity_section: None,
        ..beam.clone()
    }
    .modal_model()
    .unwrap();
    let c = (beam.youngs_modulus_pa * beam.second_moment_m4()
        / (beam.density_kg_m3 * beam.area_m2()))
    .sqrt();
    let w1 = (1.875_104_069 / beam.length_m).powi(2) * c;
    assert!((solid.modes()[0].omega_rad_s / w1 - 1.0).abs() < 1e-9);
    let shift = damped.modes()[0].omega_rad_s / w1 - 1.0;
    let (a, b) = (0.15 * 0.6, 0.15);
    let mut worst: f64 = 0.0;
    for row in rows(&d.path().join("s.csv")) {
        let ratio: f64 = row[0].parse().unwrap();
        let rms: f64 = row[4].parse().unwrap();
        let want = |m: &ModalModel| {
            let om = ratio * m.modes()[0].omega_rad_s;
            let g = m.receptance(Point::Force, Point::Response, om);
            steady_rms((g.norm(), g.arg()), 15.0, om, a, b)
        };
        let e = (rms / want(&solid) - 1.0).abs();
        worst = worst.max(e);
        assert!(
            e < 1e-7,
            "ratio {ratio}: rms_solid {rms} vs {}",
            want(&solid)
        );
        // Forced at the ratio of the bar with the hole, or read at the tip, it would be off.
        let om = ratio * damped.modes()[0].omega_rad_s;
        let g = solid.receptance(Point::Force, Point::Response, om);
        let off_ratio = (rms / steady_rms((g.norm(), g.arg()), 15.0, om, a, b) - 1.0).abs();
        let om = ratio * w1;
        let g = solid.receptance(Point::Force, Point::Force, om);
        let off_point = (rms / steady_rms((g.norm(), g.arg()), 15.0, om, a, b) - 1.0).abs();
        eprintln!("ratio {ratio}: rms_solid error {e:.2e}; with the hole's ω₁ {off_ratio:.2e}, at the tip {off_point:.2e}");
        assert!(off_ratio > 1e-3 && off_point > 0.1);
    }
    eprintln!("ω₁ shift of the hole {shift:.3e}; rms_solid vs receptance: worst {worst:.2e}");
    assert!(shift.abs() > 1e-3, "{shift}");
    // The map's metadata records both bars' modes: the solid one is the uniform beam.
    assert_ok(&vibrobar_in(
        d.path(),
        &[
            "map",
            "--scenario",
            "b.toml",
            "--ratios",
            "1:1:0.1",
            "--gaps-mm",
            "0.1:0.1:0.1",
            "--duration",
            "0.01",
            "--out",
            "m.csv",
        ],
    ));
    let p = &meta(&d.path().join("m.csv"))["parameters"];
    let w = |k: &str| p[k]["modes"][0]["omega_rad_s"].as_f64().unwrap();
    assert_eq!(w("solid_bar"), solid.modes()[0].omega_rad_s);
    assert_eq!(w("damped_bar"), damped.modes()[0].omega_rad_s);
    assert_eq!(p["beam"]["cavity_position_m"].as_f64(), Some(0.137));
}

/// `--beam-modes` and `--cavity-position-mm` reach every command that takes a system; bad input
/// names the field (and flag) with its range, and nothing is written.
#[test]
fn beam_flags_and_bad_input() {
    let d = tempfile::tempdir().unwrap();
    fs::write(d.path().join("b.toml"), FAST).unwrap();
    fs::write(d.path().join("lumped.toml"), "[run]\nsolver = \"rk4\"\n").unwrap();
    let with = |cmd: &[&str], extra: &[&str]| {
        let mut a: Vec<String> = cmd.iter().map(|s| s.to_string()).collect();
        a.extend(extra.iter().map(|s| s.to_string()));
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        vibrobar_in(d.path(), &a)
    };
    let commands: [&[&str]; 7] = [
        &["run", "--scenario", "b.toml", "--out", "o.csv"],
        &[
            "sweep",
            "--scenario",
            "b.toml",
            "--gap-mm",
            "0.1",
            "--ratios",
            "1:1:0.1",
            "--out",
            "o.csv",
        ],
        &[
            "map",
            "--scenario",
            "b.toml",
            "--ratios",
            "1:1:0.1",
            "--gaps-mm",
            "0.1:0.1:0.1",
            "--out",
            "o.csv",
        ],
        &[
            "poincare",
            "--scenario",
            "b.toml",
            "--ratio",
            "1",
            "--gap-mm",
            "0.1",
            "--out",
            "o.csv",
        ],
        &[
            "bifurcation",
            "--scenario",
            "b.toml",
            "--param",
            "ratio",
            "--values",
            "1:1:0.1",
            "--gap-mm",
            "0.1",
            "--out",
            "o.csv",
        ],
        &[
            "lyapunov",
            "--scenario",
            "b.toml",
            "--ratio",
            "1",
            "--gap-mm",
            "0.1",
            "--duration",
            "0.05",
            "--periods",
            "2",
        ],
        &[
            "ensemble",
            "--scenario",
            "b.toml",
            "--ratio",
            "1",
            "--gap-mm",
            "0.1",
            "--members",
            "2",
            "--out",
            "o.csv",
        ],
    ];
    let bad: [(&[&str], &[&str]); 6] = [
        (
            &["--cavity-position-mm", "-1"],
            &[
                "beam.cavity_position_m (--cavity-position-mm)",
                "[0, 0.175]",
            ],
        ),
        (
            &["--cavity-position-mm", "176"],
            &[
                "beam.cavity_position_m (--cavity-position-mm)",
                "[0, 0.175]",
            ],
        ),
        (
            &["--beam-modes", "0"],
            &["beam.modes (--beam-modes)", "[1, 32]"],
        ),
        (
            &["--beam-modes", "1000"],
            &["beam.modes (--beam-modes)", "[1, 32]"],
        ),
        // 32 modes: ω₃₂ ≈ 1e7 rad/s, beyond rk4's stability at dt = 2 µs.
        (&["--beam-modes", "32"], &["dt_s (--dt)", "ω_N·dt ≤ 2.5"]),
        (
            &["--solver", "exact"],
            &["N-mode exact solver is being wired in", "--solver rk4"],
        ),
    ];
    for cmd in commands {
        for (flags, want) in bad {
            let o = with(cmd, flags);
            assert_fails_with(&o, want);
            assert!(!d.path().join("o.csv").exists(), "{cmd:?} {flags:?} wrote");
        }
        // The flags need a [beam].
        let lumped: Vec<&str> = cmd
            .iter()
            .map(|s| if *s == "b.toml" { "lumped.toml" } else { s })
            .collect();
        assert_fails_with(
            &with(&lumped, &["--beam-modes", "2"]),
            &["--beam-modes and --cavity-position-mm need a scenario with a [beam] section"],
        );
        // Good flags run: the cavity at the tip, 1 mode.
        let o = with(cmd, &["--cavity-position-mm", "175", "--beam-modes", "1"]);
        assert_ok(&o);
        assert_eq!(d.path().join("o.csv").exists(), cmd[0] != "lyapunov");
        let _ = fs::remove_file(d.path().join("o.csv"));
        let _ = fs::remove_file(d.path().join("o.csv.meta.json"));
    }
    // The benches take the flags too.
    let o = with(
        &[
            "bench",
            "--scenario",
            "b.toml",
            "--single-only",
            "--solvers",
            "rk4",
        ],
        &["--beam-modes", "1", "--cavity-position-mm", "175"],
    );
    assert_ok(&o);
    assert!(String::from_utf8_lossy(&o.stdout).contains("rk4    single run"));
    for cmd in [
        &["bench", "--single-only"][..],
        &["bench-map", "--solver", "rk4"][..],
    ] {
        let mut c = cmd.to_vec();
        c.extend(["--scenario", "b.toml"]);
        assert_fails_with(
            &with(&c, &["--cavity-position-mm", "176"]),
            &[
                "beam.cavity_position_m (--cavity-position-mm)",
                "[0, 0.175]",
            ],
        );
    }
    // The file's own errors: a cavity section larger than the bar, [beam] with [bar].
    for (text, want) in [
        (
            "[beam]\n[beam.cavity_section]\nhole_diameter_m = 0.03\nlength_m = 0.01\n",
            &["beam.cavity_section.hole_diameter_m", "diameter"][..],
        ),
        (
            "[beam]\n[beam.cavity_section]\nhole_diameter_m = 0.016\nlength_m = 0.03\n",
            &["beam.cavity_section.length_m", "(0, √(D² − d_h²))"][..],
        ),
        ("[beam]\n[bar]\nmass_kg = 1\n", &["[beam] and [bar] both describe the bar"][..]),
        ("[beam]\nmodes = 0\n", &["beam.modes (--beam-modes)", "[1, 32]"][..]),
        (
            "[beam]\nmodes = 2\n[run]\nsolver = \"rk4\"\n[initial]\nu_m = 1e-6\n[beam.cavity_section]\nhole_diameter_m = 0.016\nlength_m = 0.016\n",
            &[][..],
        ),
    ] {
        fs::write(d.path().join("x.toml"), text).unwrap();
        let o = vibrobar_in(
            d.path(),
            &["run", "--scenario", "x.toml", "--duration", "0.002", "--out", "x.csv"],
        );
        if want.is_empty() {
            // An initial tip displacement goes into mode 1: accepted.
            assert_ok(&o);
            let first = &rows(&d.path().join("x.csv"))[0];
            assert_eq!(first[1].parse::<f64>().unwrap(), 1e-6, "{first:?}");
        } else {
            assert_fails_with(&o, want);
            assert!(!d.path().join("x.csv").exists());
        }
    }
}

/// A map's journal records the beam: resuming with another cavity position is refused, with
/// the same one it completes byte for byte.
#[test]
fn map_resumed_with_another_beam_is_refused() {
    let d = tempfile::tempdir().unwrap();
    fs::write(d.path().join("b.toml"), FAST).unwrap();
    let map = |out: &str, extra: &[&str]| {
        let mut a = vec![
            "map",
            "--scenario",
            "b.toml",
            "--ratios",
            "0.95:1.05:0.05",
            "--gaps-mm",
            "0.1:0.1:0.1",
            "--threads",
            "1",
            "--out",
            out,
        ];
        a.extend_from_slice(extra);
        vibrobar_in(d.path(), &a)
    };
    assert_ok(&map("full.csv", &[]));
    assert_ok(&map("moved.csv", &["--cavity-position-mm", "150"]));
    let fp = |f: &str| {
        meta(&d.path().join(f))["fingerprint"]
            .as_str()
            .unwrap()
            .to_string()
    };
    assert_ne!(fp("full.csv"), fp("moved.csv"));
    let full: Vec<String> = fs::read_to_string(d.path().join("full.csv"))
        .unwrap()
        .lines()
        .map(str::to_string)
        .collect();
    assert_ne!(
        fs::read_to_string(d.path().join("full.csv")).unwrap(),
        fs::read_to_string(d.path().join("moved.csv")).unwrap()
    );
    // A journal of the 137 mm map with one row done.
    let journal = format!(
        "# vibrobar journal v1 fingerprint={}\nindex,{}\n0,{}\n",
        fp("full.csv"),
        full[0],
        full[1]
    );
    fs::write(d.path().join("part.csv.journal"), &journal).unwrap();
    let o = map("part.csv", &["--resume", "--cavity-position-mm", "150"]);
    assert_fails_with(&o, &["different parameters"]);
    assert!(!d.path().join("part.csv").exists());
    assert_ok(&map("part.csv", &["--resume"]));
    assert_eq!(
        fs::read(d.path().join("part.csv")).unwrap(),
        fs::read(d.path().join("full.csv")).unwrap()
    );
}
