//! `vibrobar fit-modes` end to end: a synthetic tap test written as UFF 58b is fitted back to its
//! modes, the TOML it writes is a scenario every command reads, and bad input writes nothing.

mod common;

use common::{assert_fails_with, names, s, vibrobar_in};
use num_complex::Complex64;
use std::f64::consts::PI;
use std::fs;
use vibrobar_core::structure::frf_data::{FrfKind, MeasuredFrf};
use vibrobar_io::frf::{write_frf_uff, Uff58Header};

const TRUE: [(f64, f64, f64, f64); 3] = [
    (597.51, 0.01, 0.15637, 0.70066),
    (3588.7, 0.012, 0.16333, -0.015423),
    (10057.0, 0.02, 0.17623, -0.55646),
];

fn frf(cross: bool) -> MeasuredFrf {
    let f: Vec<f64> = (1..=6000).map(|k| 2.0 * k as f64).collect();
    let h = f
        .iter()
        .map(|&fh| {
            let w = 2.0 * PI * fh;
            TRUE.iter()
                .map(|&(fr, z, m, sh)| {
                    let wn = 2.0 * PI * fr;
                    let phi = if cross { sh } else { 1.0 };
                    -w * w * phi / (m * Complex64::new(wn * wn - w * w, 2.0 * z * wn * w))
                })
                .sum()
        })
        .collect();
    MeasuredFrf::new(f, h, FrfKind::Accelerance, None, !cross, String::new()).unwrap()
}

#[test]
fn a_tap_test_in_uff58b_is_fitted_back_to_its_modes() {
    let dir = tempfile::tempdir().unwrap();
    let tip = dir.path().join("tip.uff");
    let cross = dir.path().join("cross.uff");
    write_frf_uff(&tip, &frf(false), &Uff58Header::default(), true).unwrap();
    let hdr = Uff58Header {
        rsp_node: 2,
        ..Uff58Header::default()
    };
    write_frf_uff(&cross, &frf(true), &hdr, true).unwrap();
    let o = vibrobar_in(
        dir.path(),
        &[
            "fit-modes",
            "--frf",
            s(&tip),
            "--cross",
            s(&cross),
            "--out",
            "modes.toml",
        ],
    );
    common::assert_ok(&o);
    let toml_text = fs::read_to_string(dir.path().join("modes.toml")).unwrap();
    assert!(toml_text.contains("WITHOUT the ball"));
    let v: toml::Value = toml::from_str(&toml_text).unwrap();
    let modes = v["modes"].as_array().unwrap();
    assert_eq!(modes.len(), 3);
    for (m, &(f, z, mass, sh)) in modes.iter().zip(&TRUE) {
        let g = |k: &str| m[k].as_float().unwrap();
        assert!((g("frequency_hz") / f - 1.0).abs() < 1e-6);
        assert!((g("damping_ratio") / z - 1.0).abs() < 1e-6);
        assert!((g("modal_mass_kg") / mass - 1.0).abs() < 1e-6);
        assert!((g("shape_cavity") - sh).abs() < 1e-6);
    }
    for f in [
        "modes.stabilisation.csv",
        "modes.stabilisation.png",
        "modes.stabilisation.svg",
        "modes.fit.csv",
        "modes.fit.png",
        "modes.fit.svg",
    ] {
        assert!(
            dir.path().join(f).is_file(),
            "{f} missing: {:?}",
            names(dir.path())
        );
    }
    // The TOML is a scenario: the modes command reads it.
    let o = vibrobar_in(
        dir.path(),
        &["modes", "--scenario", "modes.toml", "--out", "m.csv"],
    );
    common::assert_ok(&o);
    let csv = fs::read_to_string(dir.path().join("m.csv")).unwrap();
    assert!(csv.lines().count() == 4, "{csv}");
    // Lobes from the measured FRF carry the fitted modes' minimum beside the measured one, and
    // on clean data the two agree.
    let sc = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenarios/measured_modes.toml"
    );
    let o = vibrobar_in(
        dir.path(),
        &[
            "lobes",
            "--scenario",
            sc,
            "--frf",
            s(&tip),
            "--rpm",
            "1000:50000:500",
            "--out",
            "l.csv",
        ],
    );
    common::assert_ok(&o);
    let out = String::from_utf8_lossy(&o.stdout);
    let pct = out
        .lines()
        .find(|l| l.contains("fitted     : b_lim,min"))
        .and_then(|l| l.split("defaults: ").nth(1))
        .and_then(|t| t.split(" %").next())
        .map(|t| t.trim().parse::<f64>().unwrap())
        .unwrap_or_else(|| panic!("no fitted line in\n{out}"));
    assert!(pct.abs() < 0.1, "fitted against measured: {pct} %");
}

#[test]
fn bad_input_is_refused_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let tip = dir.path().join("tip.uff");
    write_frf_uff(&tip, &frf(false), &Uff58Header::default(), false).unwrap();
    fs::write(dir.path().join("junk.uff"), "hello\n").unwrap();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["--frf", "junk.uff"], "not a universal file"),
        (vec!["--frf", s(&tip), "--band-hz", "1:5000"], "--band-hz"),
        (vec!["--frf", s(&tip), "--band-hz", "100"], "LOW:HIGH"),
        (vec!["--frf", s(&tip), "--max-order", "31"], "--max-order"),
        (vec!["--frf", s(&tip), "--max-order", "1000"], "--max-order"),
        (vec!["--frf", s(&tip), "--poles-hz", "2000"], "--poles-hz"),
        (vec!["--frf", s(&tip), "--length-mm", "160"], "go together"),
        (
            vec!["--frf", s(&tip), "--pseudo-mode-hz", "100"],
            "--pseudo-mode-hz",
        ),
        (
            vec!["--frf", s(&tip), "--frf-type", "velocity"],
            "--frf-type",
        ),
    ];
    for (args, want) in cases {
        let mut a = vec!["fit-modes"];
        a.extend(args);
        a.extend(["--out", "m.toml"]);
        let o = vibrobar_in(dir.path(), &a);
        assert_fails_with(&o, &[want]);
        assert!(!dir.path().join("m.toml").exists(), "{a:?} wrote m.toml");
    }
}
