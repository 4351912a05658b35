//! Issue #8 part 1, end to end: `vibrobar modes` on the paper's geometry, the `[beam]` contract,
//! bad input (every error names the field and its range, nothing written), and no simulating
//! command silently running the lumped bar on a `[beam]` scenario.

mod common;

use common::{assert_fails_with, vibrobar_in};
use std::path::Path;

const PAPER_BEAM: &str = "[beam]\nlength_m = 0.175\ndiameter_m = 0.025\n\
    youngs_modulus_pa = 200e9\ndensity_kg_m3 = 7850.0\ncavity_position_m = 0.137\n";

fn read_rows(p: &Path) -> (String, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(p).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().to_string();
    let rows = lines
        .map(|l| l.split(',').map(|f| f.parse::<f64>().unwrap()).collect())
        .collect();
    (header, rows)
}

#[test]
fn modes_of_the_paper_geometry() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("b.toml"), PAPER_BEAM).unwrap();
    let o = vibrobar_in(
        dir.path(),
        &["modes", "--scenario", "b.toml", "--out", "m.csv"],
    );
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (header, rows) = read_rows(&dir.path().join("m.csv"));
    assert_eq!(
        header,
        "mode,frequency_hz,modal_mass_kg,shape_cavity,shape_force,shape_response"
    );
    // Default N = 3; f = (βₙL)²/(2πL²)·√(EI/ρA); ρAL/4 = 0.1686 kg; φ₁ 38 mm from the free end ≈ 0.70;
    // the cavity sits almost on the node of mode 2.
    assert_eq!(rows.len(), 3);
    for (k, (f, phi)) in [(576.441, 0.7022), (3612.50, -0.0024), (10115.09, -0.4704)]
        .iter()
        .enumerate()
    {
        let r = &rows[k];
        assert_eq!(r[0], (k + 1) as f64);
        assert!((r[1] - f).abs() < 0.01, "mode {}: {} Hz", k + 1, r[1]);
        assert!((r[2] - 0.168_584).abs() < 1e-6, "modal mass {}", r[2]);
        assert!((r[3] - phi).abs() < 1e-4, "φ(cavity) {}", r[3]);
        assert_eq!((r[4], r[5]), (1.0, 1.0));
    }
    assert!(stdout.contains("99.8556 % captured"), "{stdout}");
    assert!(stdout.contains("shapes 1 at the tip"), "{stdout}");
    assert!(
        stdout.contains("cavity 38 mm from the free end"),
        "{stdout}"
    );
    assert!(dir.path().join("m.csv.meta.json").exists());
    // Flags: N and the cavity position.
    let o = vibrobar_in(
        dir.path(),
        &[
            "modes",
            "--scenario",
            "b.toml",
            "--out",
            "m5.csv",
            "--beam-modes",
            "5",
            "--cavity-position-mm",
            "175",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (_, rows) = read_rows(&dir.path().join("m5.csv"));
    assert_eq!(rows.len(), 5);
    assert!(rows.iter().all(|r| (r[3] - 1.0).abs() < 1e-12));
}

/// The example scenario shipped in `scenarios/` gives the same modes as the inline one.
#[test]
fn shipped_beam_scenario_gives_the_paper_geometry_modes() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("b.toml"), PAPER_BEAM).unwrap();
    let shipped = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenarios/paper_beam.toml"
    );
    let a = vibrobar_in(
        dir.path(),
        &["modes", "--scenario", shipped, "--out", "a.csv"],
    );
    let b = vibrobar_in(
        dir.path(),
        &["modes", "--scenario", "b.toml", "--out", "b.csv"],
    );
    assert!(a.status.success(), "{}", String::from_utf8_lossy(&a.stderr));
    assert!(b.status.success());
    let read = |f: &str| std::fs::read_to_string(dir.path().join(f)).unwrap();
    assert_eq!(read("a.csv"), read("b.csv"));
}

#[test]
fn modes_of_the_lumped_bar_is_its_one_mode() {
    let dir = tempfile::tempdir().unwrap();
    let o = vibrobar_in(dir.path(), &["modes", "--out", "m.csv"]);
    assert!(o.status.success());
    let text = std::fs::read_to_string(dir.path().join("m.csv")).unwrap();
    let want = format!(
        "mode,frequency_hz,modal_mass_kg,shape_cavity,shape_force,shape_response\n1,{},0.644,1,1,1\n",
        (9.22e6f64 / 0.644).sqrt() / (2.0 * std::f64::consts::PI)
    );
    assert_eq!(text, want);
    // The beam flags need a [beam].
    let o = vibrobar_in(
        dir.path(),
        &["modes", "--out", "n.csv", "--beam-modes", "4"],
    );
    assert_fails_with(&o, &["need a scenario with a [beam] section"]);
    assert!(!dir.path().join("n.csv").exists());
}

#[test]
fn modes_with_cavity_section_and_tip_mass_uses_finite_elements() {
    let dir = tempfile::tempdir().unwrap();
    let text = format!(
        "{PAPER_BEAM}[beam.cavity_section]\nhole_diameter_m = 0.0151\nlength_m = 0.017\n\
         [beam.tip_mass]\nmass_kg = 0.05\nrotary_inertia_kg_m2 = 1e-6\n"
    );
    std::fs::write(dir.path().join("b.toml"), text).unwrap();
    let o = vibrobar_in(
        dir.path(),
        &["modes", "--scenario", "b.toml", "--out", "m.csv"],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("finite elements"));
    let (_, rows) = read_rows(&dir.path().join("m.csv"));
    assert!(rows.len() >= 3);
    // A 50 g tip mass lowers f₁ well below the bare bar's 576 Hz.
    assert!(
        rows[0][1] < 560.0 && rows[0][1] > 400.0,
        "f₁ = {}",
        rows[0][1]
    );
}

#[test]
fn bad_beam_input_names_the_field_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    for (extra, flags, want) in [
        (
            "cavity_position_m = 0.2\n",
            &[][..],
            "beam.cavity_position_m",
        ),
        ("", &["--cavity-position-mm", "-1"][..], "[0, 0.175]"),
        (
            "force_position_m = 0.18\n",
            &[][..],
            "beam.force_position_m",
        ),
        (
            "response_position_m = -0.01\n",
            &[][..],
            "beam.response_position_m",
        ),
        (
            "",
            &["--beam-modes", "0"][..],
            "beam.modes (--beam-modes) = 0 is outside the allowed range [1, 32]",
        ),
        ("", &["--beam-modes", "100000"][..], "[1, 32]"),
        ("modes = 0\n", &[][..], "beam.modes"),
        ("youngs_modulus_pa = 0\n", &[][..], "beam.youngs_modulus_pa"),
        ("density_kg_m3 = -7850\n", &[][..], "beam.density_kg_m3"),
        ("length_m = 0\n", &[][..], "beam.length_m"),
        ("diameter_m = -0.025\n", &[][..], "beam.diameter_m"),
        (
            "[beam.cavity_section]\nhole_diameter_m = 0.03\nlength_m = 0.01\n",
            &[][..],
            "beam.cavity_section.hole_diameter_m",
        ),
        (
            "[beam.cavity_section]\nhole_diameter_m = 0.0151\nlength_m = 0.03\n",
            &[][..],
            "beam.cavity_section.length_m",
        ),
    ] {
        // Scalar fields go before the sub-tables of PAPER_BEAM's [beam]: a fresh file each time.
        let text = if extra.starts_with('[') {
            format!("{PAPER_BEAM}{extra}")
        } else {
            format!("[beam]\n{extra}")
        };
        std::fs::write(dir.path().join("b.toml"), text).unwrap();
        let mut args = vec!["modes", "--scenario", "b.toml", "--out", "m.csv"];
        args.extend_from_slice(flags);
        let o = vibrobar_in(dir.path(), &args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{extra:?} {flags:?} succeeded");
        assert!(err.contains(want), "{extra:?} {flags:?}: {err}");
        assert!(
            !dir.path().join("m.csv").exists(),
            "{extra:?}: a file was written"
        );
        assert!(!dir.path().join("m.csv.partial").exists());
    }
    // A cavity longer than the bar (a short bar with the paper's hole).
    std::fs::write(
        dir.path().join("b.toml"),
        "[beam]\nlength_m = 0.01\ncavity_position_m = 0.005\n\
         [beam.cavity_section]\nhole_diameter_m = 0.015\nlength_m = 0.01\n",
    )
    .unwrap();
    let o = vibrobar_in(
        dir.path(),
        &["modes", "--scenario", "b.toml", "--out", "m.csv"],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("beam.cavity_section.hole_diameter_m"), "{err}");
    assert!(err.contains("length_m"), "{err}");
}

#[test]
fn beam_and_bar_together_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("b.toml"),
        format!("{PAPER_BEAM}[bar]\ndamping_ratio = 0.02\n"),
    )
    .unwrap();
    let o = vibrobar_in(
        dir.path(),
        &["modes", "--scenario", "b.toml", "--out", "m.csv"],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("[beam] and [bar] both describe the bar"),
        "{err}"
    );
}

/// A `[beam]` scenario never runs the lumped bar silently. Every simulating command runs it on
/// its modes (tests/beam_commands.rs); with the default solver, `exact`, whose N-mode form is
/// being wired in, each fails with that message and writes nothing.
#[test]
fn regression_beam_scenario_never_runs_the_lumped_bar_silently() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("b.toml"), PAPER_BEAM).unwrap();
    let s = ["--scenario", "b.toml"];
    let cases: Vec<Vec<&str>> = vec![
        vec!["run", "--out", "o.csv"],
        vec!["run", "--out", "o.csv", "--energy"],
        vec!["sweep", "--out", "o.csv"],
        vec![
            "map",
            "--out",
            "o.csv",
            "--ratios",
            "1:1:0.1",
            "--gaps-mm",
            "0.1:0.1:0.1",
        ],
        vec![
            "poincare", "--out", "o.csv", "--ratio", "1", "--gap-mm", "0.1",
        ],
        vec![
            "bifurcation",
            "--out",
            "o.csv",
            "--param",
            "ratio",
            "--values",
            "1:1:0.1",
            "--gap-mm",
            "0.1",
        ],
        vec!["lyapunov", "--ratio", "1", "--gap-mm", "0.1"],
        vec![
            "ensemble",
            "--out",
            "o.csv",
            "--ratio",
            "1",
            "--gap-mm",
            "0.1",
            "--members",
            "2",
        ],
        vec!["bench", "--single-only", "--duration", "0.01"],
        // With every solver, bench-map would first time rk4 on the beam (30 s of runs).
        vec!["bench-map", "--solver", "exact"],
    ];
    for mut args in cases {
        args.extend_from_slice(&s);
        let o = vibrobar_in(dir.path(), &args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert!(
            err.contains("the exact solver does not run a modal bar (a [beam] scenario) yet"),
            "{args:?}: {err}"
        );
        assert!(!dir.path().join("o.csv").exists(), "{args:?} wrote a file");
    }
}
