//! `vibrobar tap-test` end to end on a small grid: the universal files it writes are read back
//! by `fit-modes` and `lobes --frf` to the numbers its document states, the fitted modes are the
//! true ones within the stated tolerances, and bad input writes nothing.

mod common;

use common::{assert_fails_with, assert_ok, vibrobar_in};
use std::fs;

/// The small grid: every step of the example, a few runs each.
const SMALL: [&str; 16] = [
    "--lobes-rpm",
    "2000:20000:200",
    "--positions-mm",
    "120:160:40",
    "--gaps-mm",
    "0.1:0.1:1",
    "--ratios",
    "0.99:1.01:0.02",
    "--forced-duration",
    "0.2",
    "--ball-masses-g",
    "26:26:1",
    "--design-rpm",
    "5000:5000:1",
    "--threads",
    "2",
];

fn number_after(text: &str, key: &str) -> f64 {
    let i = text
        .find(key)
        .unwrap_or_else(|| panic!("{key:?} not in {text}"));
    text[i + key.len()..]
        .trim_start()
        .split(|c: char| !(c.is_ascii_digit() || "+-.e".contains(c)))
        .next()
        .and_then(|w| w.parse().ok())
        .unwrap_or_else(|| panic!("no number after {key:?}"))
}

#[test]
fn the_worked_example_is_consistent_with_the_commands_it_names() {
    let dir = tempfile::tempdir().unwrap();
    let mut args = vec!["tap-test", "--out", "doc/tap-test.md"];
    args.extend(SMALL);
    assert_ok(&vibrobar_in(dir.path(), &args));
    let doc = fs::read_to_string(dir.path().join("doc/tap-test.md")).unwrap();
    let sub = dir.path().join("doc/tap-test");
    for f in [
        "tip.uff",
        "cross.uff",
        "modes.toml",
        "modes.stabilisation.png",
        "modes.fit.svg",
        "lobes.csv",
        "lobes.png",
        "placement.csv",
        "placement.svg",
        "design.toml",
        "design.csv",
        "design.png",
        "cut.toml",
    ] {
        assert!(sub.join(f).is_file(), "{f} missing");
    }
    for f in [
        "tip.uff",
        "cross.uff",
        "modes.toml",
        "modes.stabilisation.png",
        "modes.fit.png",
        "lobes.png",
        "placement.png",
        "design.toml",
        "design.png",
    ] {
        assert!(doc.contains(&format!("(tap-test/{f})")), "{f} not linked");
    }

    // The fitted modes from the noisy record: frequencies within 0.1 %, damping within 5 %.
    let modes = fs::read_to_string(sub.join("modes.toml")).unwrap();
    let t: toml::Value = toml::from_str(&modes).unwrap();
    let m = t["modes"].as_array().unwrap();
    assert_eq!(m.len(), 3);
    for (k, (f, z)) in [(597.51, 0.01), (3588.7, 0.012), (10057.0, 0.02)]
        .into_iter()
        .enumerate()
    {
        let ff = m[k]["frequency_hz"].as_float().unwrap();
        let zz = m[k]["damping_ratio"].as_float().unwrap();
        assert!((ff / f - 1.0).abs() < 1e-3, "mode {k}: {ff} Hz");
        assert!((zz / z - 1.0).abs() < 0.05, "mode {k}: ζ = {zz}");
    }

    // The document's lobe minimum from the measured lines is what `lobes --frf` prints from the
    // same file; the fitted one within 2 % of the true bar's.
    let out = vibrobar_in(
        dir.path(),
        &[
            "lobes",
            "--frf",
            "doc/tap-test/tip.uff",
            "--scenario",
            "doc/tap-test/cut.toml",
            "--rpm",
            "2000:20000:200",
            "--out",
            "lm.csv",
        ],
    );
    assert_ok(&out);
    assert!(dir.path().join("lm.png").is_file() && dir.path().join("lm.svg").is_file());
    let printed_mm = number_after(&String::from_utf8_lossy(&out.stdout), "b_lim,min =");
    let doc_um = number_after(&doc, "| the measured lines (spline, no fit) |");
    assert!(
        (printed_mm * 1e3 / doc_um - 1.0).abs() < 1e-4,
        "lobes --frf {printed_mm} mm, document {doc_um} µm"
    );
    let true_um = number_after(&doc, "| the true bar |");
    let fitted_um = number_after(&doc, "| the modes fitted to the noisy record |");
    assert!((fitted_um / true_um - 1.0).abs() < 0.02);

    // The design table has the solid bar beside it and a finite width.
    assert!(doc.contains("The bar without the ball: worst"));
    let csv = fs::read_to_string(sub.join("design.csv")).unwrap();
    assert_eq!(csv.lines().count(), 2, "{csv}");
}

#[test]
fn bad_input_names_the_flag_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    for (flag, value, want) in [
        ("--positions-mm", "120:400:40", "--positions-mm"),
        ("--forced-duration", "-1", "--forced-duration"),
        ("--gaps-mm", "0:0.1:0.1", "--gaps-mm"),
        ("--lobes-rpm", "2000:1e9:10", "rpm"),
    ] {
        let mut args = vec!["tap-test", "--out", "doc/tap-test.md"];
        args.extend(SMALL);
        let i = args.iter().position(|a| *a == flag).unwrap();
        args[i + 1] = value;
        assert_fails_with(&vibrobar_in(dir.path(), &args), &[want]);
        assert!(
            !dir.path().join("doc").exists(),
            "{flag} {value}: wrote files"
        );
    }
    let o = vibrobar_in(dir.path(), &["tap-test", "--out", "doc.txt"]);
    assert_fails_with(&o, &["--out", ".md"]);
}
