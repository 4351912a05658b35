//! One input path: every command that takes a system accepts `--scenario FILE`, and the file's
//! values reach the runs (checked against the core directly, not only in the metadata).

mod common;

use common::{assert_fails_with, s, vibrobar, vibrobar_ok};
use std::fs;
use std::path::{Path, PathBuf};

use vibrobar_core::analysis::map::{compute_point, Axis, GridPoint, MapSpec};
use vibrobar_core::analysis::regime::Tolerances;
use vibrobar_core::analysis::run_case;
use vibrobar_core::solver::Rk4;
use vibrobar_core::{Bar, Damper, FrictionModel, RunSettings, State, System};

/// A user's own bar: lighter-than-paper stiffness, heavier ball, coulomb friction, rk4.
const OWN: &str = r#"
[bar]
mass_kg = 1.0
stiffness_n_per_m = 4.0e6
[solid_bar]
mass_kg = 1.03
[damper]
ball_mass_kg = 0.05
gap_m = 2.0e-4
friction = "coulomb"
[run]
duration_s = 0.04
dt_s = 2.0e-6
solver = "rk4"
"#;

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    fs::write(&p, text).unwrap();
    p
}

fn meta(data: &Path) -> serde_json::Value {
    let mut m = data.as_os_str().to_owned();
    m.push(".meta.json");
    serde_json::from_str(&fs::read_to_string(m).unwrap()).unwrap()
}

/// What the file says, as core types.
fn own_bar() -> Bar {
    Bar {
        mass_kg: 1.0,
        stiffness_n_per_m: 4.0e6,
        ..Bar::PAPER_CAVITY
    }
}

fn own_solid() -> Bar {
    Bar {
        mass_kg: 1.03,
        ..Bar::PAPER_SOLID
    }
}

fn own_ball() -> Damper {
    Damper {
        ball_mass_kg: 0.05,
        gap_m: 2.0e-4,
        friction: FrictionModel::Coulomb,
        ..Damper::default()
    }
}

fn own_settings() -> RunSettings {
    RunSettings {
        duration_s: 0.04,
        dt_s: 2.0e-6,
        ..RunSettings::default()
    }
}

/// The parameters every design command records for the own scenario.
fn assert_own_params(p: &serde_json::Value) {
    assert_eq!(p["damped_bar"]["mass_kg"], 1.0, "{p}");
    assert_eq!(p["damped_bar"]["stiffness_n_per_m"], 4.0e6, "{p}");
    assert_eq!(p["solid_bar"]["mass_kg"], 1.03, "{p}");
    assert_eq!(p["ball"]["ball_mass_kg"], 0.05, "{p}");
    assert_eq!(p["friction"], "coulomb", "{p}");
    assert_eq!(p["solver"], "rk4", "{p}");
    assert_eq!(p["settings"]["dt_s"], 2.0e-6, "{p}");
}

#[test]
fn a_user_can_map_their_own_bar() {
    let d = tempfile::tempdir().unwrap();
    let sc = write(d.path(), "own.toml", OWN);
    let out = d.path().join("m.csv");
    // No --friction: the file's coulomb law is used.
    vibrobar_ok(&[
        "map",
        "--scenario",
        s(&sc),
        "--ratios",
        "0.98:1.02:0.04",
        "--gaps-mm",
        "0.1:0.2:0.1",
        "--out",
        s(&out),
    ]);
    assert_own_params(&meta(&out)["parameters"]);
    let text = fs::read_to_string(&out).unwrap();
    let rows: Vec<Vec<&str>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert_eq!(rows.len(), 4);
    // The rows are the core's runs of the user's bar, bit for bit.
    let spec = MapSpec {
        base: vibrobar_core::analysis::SweepBase {
            damped_bar: own_bar().into(),
            solid_bar: own_solid().into(),
            ball: own_ball(),
            ..vibrobar_core::analysis::SweepBase::paper()
        },
        friction: FrictionModel::Coulomb,
        settings: own_settings(),
        tolerances: Tolerances::default(),
    };
    let solver = Rk4 { dt_s: 2.0e-6 };
    for (i, (ratio, gap_m)) in [(0.98, 1e-4), (0.98, 2e-4), (1.02, 1e-4), (1.02, 2e-4)]
        .into_iter()
        .enumerate()
    {
        let p = GridPoint {
            index: i,
            coords: vec![(Axis::FreqRatio, ratio), (Axis::GapM, gap_m)],
        };
        let want = compute_point(&spec, &solver, &p).unwrap();
        let solid: f64 = rows[i][2].parse().unwrap();
        let damped: f64 = rows[i][3].parse().unwrap();
        assert_eq!(solid.to_bits(), want.rms_solid_m.to_bits(), "row {i}");
        assert_eq!(damped.to_bits(), want.rms_damped_m.to_bits(), "row {i}");
    }
    // The solid bar really is the file's: not the paper's.
    let paper_solid = run_case(
        &System::paper_solid(0.98),
        &State::REST,
        &own_settings(),
        &solver,
        &mut (),
    )
    .unwrap()
    .rms_m;
    assert_ne!(rows[0][2].parse::<f64>().unwrap(), paper_solid);
    // Flags override the file.
    let out2 = d.path().join("m2.csv");
    vibrobar_ok(&[
        "map",
        "--scenario",
        s(&sc),
        "--friction",
        "none",
        "--duration",
        "0.02",
        "--ratios",
        "1:1:0.01",
        "--gaps-mm",
        "0.2:0.2:0.1",
        "--out",
        s(&out2),
    ]);
    let p = &meta(&out2)["parameters"];
    assert_eq!(p["friction"], "none");
    assert_eq!(p["settings"]["duration_s"], 0.02);
    assert_eq!(p["damped_bar"]["mass_kg"], 1.0);
    // --scenario and --preset exclude each other.
    let o = vibrobar(&[
        "map",
        "--scenario",
        s(&sc),
        "--preset",
        "paper",
        "--ratios",
        "1:1:0.01",
        "--gaps-mm",
        "0.2:0.2:0.1",
        "--out",
        s(&out2),
    ]);
    assert_fails_with(&o, &["--preset"]);
}

#[test]
fn poincare_bifurcation_lyapunov_ensemble_take_a_scenario() {
    let d = tempfile::tempdir().unwrap();
    let sc = write(d.path(), "own.toml", OWN);
    let p = d.path().join("p.csv");
    vibrobar_ok(&[
        "poincare",
        "--scenario",
        s(&sc),
        "--ratio",
        "1",
        "--gap-mm",
        "0.2",
        "--out",
        s(&p),
    ]);
    assert_own_params(&meta(&p)["parameters"]);
    // The same point of the paper's bar gives another section: the file reached the run.
    let pp = d.path().join("pp.csv");
    vibrobar_ok(&[
        "poincare",
        "--friction",
        "coulomb",
        "--solver",
        "rk4",
        "--dt",
        "2e-6",
        "--duration",
        "0.04",
        "--ratio",
        "1",
        "--gap-mm",
        "0.2",
        "--out",
        s(&pp),
    ]);
    assert_ne!(fs::read(&p).unwrap(), fs::read(&pp).unwrap());

    let b = d.path().join("b.csv");
    vibrobar_ok(&[
        "bifurcation",
        "--scenario",
        s(&sc),
        "--param",
        "gap-mm",
        "--values",
        "0.1:0.2:0.1",
        "--ratio",
        "1",
        "--out",
        s(&b),
    ]);
    assert_own_params(&meta(&b)["parameters"]);

    let o = vibrobar_ok(&[
        "lyapunov",
        "--scenario",
        s(&sc),
        "--ratio",
        "1",
        "--gap-mm",
        "0.2",
        "--periods",
        "2",
        "--json",
    ]);
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_own_params(&j["parameters"]);
    assert!(j["exponent_per_s"].as_f64().unwrap().is_finite());

    let e = d.path().join("e.csv");
    vibrobar_ok(&[
        "ensemble",
        "--scenario",
        s(&sc),
        "--ratio",
        "1",
        "--gap-mm",
        "0.2",
        "--members",
        "2",
        "--out",
        s(&e),
    ]);
    assert_own_params(&meta(&e)["parameters"]);
}

#[test]
fn bench_and_bench_map_take_a_scenario() {
    let d = tempfile::tempdir().unwrap();
    let sc = write(d.path(), "own.toml", OWN);
    let o = vibrobar_ok(&[
        "bench",
        "--scenario",
        s(&sc),
        "--solvers",
        "rk4",
        "--single-only",
    ]);
    let text = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(
        text.contains("scenario: r = 1, gap 0.2 mm, friction coulomb"),
        "{text}"
    );
    // Its RMS is the one `run` gives for the same file.
    let r = vibrobar_ok(&[
        "run",
        "--scenario",
        s(&sc),
        "--out",
        s(&d.path().join("r.csv")),
    ]);
    let rms_line = String::from_utf8_lossy(&r.stdout)
        .lines()
        .find(|l| l.contains("RMS u"))
        .map(|l| {
            l.split(':')
                .nth(1)
                .unwrap()
                .trim()
                .trim_end_matches(" m")
                .to_string()
        })
        .unwrap();
    assert!(
        text.contains(&format!("RMS {rms_line} m")),
        "{text} vs {rms_line}"
    );
    // The scenario's sweep: one gap (the file's) × 11 ratios.
    let o = vibrobar_ok(&[
        "bench",
        "--scenario",
        s(&sc),
        "--solvers",
        "rk4",
        "--duration",
        "0.005",
    ]);
    let text = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(text.contains("scenario sweep (11 damped points"), "{text}");
    let o = vibrobar_ok(&[
        "bench-map",
        "--scenario",
        s(&sc),
        "--ratios",
        "2",
        "--gaps",
        "2",
        "--subsample",
        "2",
        "--solver",
        "rk4",
    ]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("0.04 s per run"));
}

#[test]
fn regression_sweep_uses_the_files_gap_when_it_has_no_sweep_section() {
    let d = tempfile::tempdir().unwrap();
    let sc = write(d.path(), "gap.toml", "[damper]\ngap_m = 5.0e-4\n");
    let out = d.path().join("s.csv");
    vibrobar_ok(&[
        "sweep",
        "--scenario",
        s(&sc),
        "--ratios",
        "1:1:0.01",
        "--duration",
        "0.02",
        "--out",
        s(&out),
    ]);
    let text = fs::read_to_string(&out).unwrap();
    let gaps: Vec<&str> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap())
        .collect();
    assert_eq!(gaps, ["0.5"], "{text}");
}

#[test]
fn regression_bar_or_solid_bar_with_one_field_runs() {
    let d = tempfile::tempdir().unwrap();
    for (name, text) in [
        ("bar.toml", "[bar]\ndamping_ratio = 0.02\n"),
        ("solid.toml", "[solid_bar]\ndamping_ratio = 0.02\n"),
    ] {
        let sc = write(d.path(), name, text);
        vibrobar_ok(&[
            "sweep",
            "--scenario",
            s(&sc),
            "--ratios",
            "1:1:0.01",
            "--gap-mm",
            "0.1",
            "--duration",
            "0.02",
            "--out",
            s(&d.path().join(format!("{name}.csv"))),
        ]);
    }
}

#[test]
fn a_bad_scenario_fails_every_command_before_any_run_naming_the_field() {
    let d = tempfile::tempdir().unwrap();
    let solid = write(d.path(), "solid.toml", "[solid_bar]\nmass_kg = 0\n");
    let ball = write(d.path(), "ball.toml", "[initial]\nw_m = 4.0e-5\n");
    let out = d.path().join("x.csv");
    let o = s(&out);
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec![
                "map",
                "--scenario",
                s(&solid),
                "--ratios",
                "1:1:0.1",
                "--gaps-mm",
                "0.1:0.1:0.1",
                "--out",
                o,
            ],
            "solid_bar.mass_kg",
        ),
        (
            vec![
                "poincare",
                "--scenario",
                s(&solid),
                "--ratio",
                "1",
                "--gap-mm",
                "0.1",
                "--out",
                o,
            ],
            "solid_bar.mass_kg",
        ),
        // w = 40 µm fits the file's 0.1 mm gap but not a 0.05 mm grid point.
        (
            vec![
                "map",
                "--scenario",
                s(&ball),
                "--ratios",
                "1:1:0.1",
                "--gaps-mm",
                "0.05:0.1:0.05",
                "--out",
                o,
            ],
            "initial.w_m",
        ),
        (
            vec![
                "lyapunov",
                "--scenario",
                s(&ball),
                "--ratio",
                "1",
                "--gap-mm",
                "0.05",
            ],
            "initial.w_m",
        ),
        (
            vec![
                "bifurcation",
                "--scenario",
                s(&ball),
                "--param",
                "gap-mm",
                "--values",
                "0.05:0.1:0.05",
                "--ratio",
                "1",
                "--out",
                o,
            ],
            "initial.w_m",
        ),
    ];
    for (args, want) in cases {
        let r = vibrobar(&args);
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(!r.status.success(), "{args:?} accepted");
        assert!(err.contains(want), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert!(!out.exists(), "{args:?} wrote output");
    }
}
