//! `vibrobar frf` end to end: the CSV (its header, the core's numbers to the last bit), the
//! metadata, the figure, every structure (lumped, `[beam]`, `[[modes]]`), the stepped sine and
//! the tap test, bad input, and outputs that must not replace an input.

mod common;

use common::{assert_fails_with, names, s, vibrobar_in};
use std::fs;
use std::path::Path;
use vibrobar_core::analysis::frf::linear_frf;
use vibrobar_core::params::BarModel;
use vibrobar_core::structure::{Point, Structure};
use vibrobar_scenario::Scenario;

const MODES: &str = "[[modes]]\nfrequency_hz = 600\ndamping_ratio = 0.01\nmodal_mass_kg = 0.155\nshape_cavity = 0.9\n\
                     [[modes]]\nfrequency_hz = 3760\ndamping_ratio = 0.015\nmodal_mass_kg = 0.155\nshape_cavity = -0.4\n";

fn table(p: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = fs::read_to_string(p).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    (header, rows)
}

#[test]
fn frf_of_every_structure_writes_the_core_numbers_metadata_and_a_figure() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (name, text) in [
        ("lumped", String::new()),
        (
            "beam",
            "[beam]\nmodes = 3\n[beam.cavity_section]\nhole_diameter_m = 0.015\nlength_m = 0.017\n"
                .to_string(),
        ),
        ("modes", MODES.to_string()),
    ] {
        let sc_path = d.join(format!("{name}.toml"));
        fs::write(&sc_path, &text).unwrap();
        let out = d.join(format!("{name}.csv"));
        let o = vibrobar_in(
            d,
            &[
                "frf",
                "--scenario",
                s(&sc_path),
                "--band-hz",
                "100:5000:10",
                "--from",
                "force",
                "--to",
                "cavity",
                "--out",
                s(&out),
            ],
        );
        common::assert_ok(&o);
        let (header, rows) = table(&out);
        assert_eq!(
            header[..9].join(","),
            "frequency_hz,solid_re_m_per_n,solid_im_m_per_n,solid_mag_m_per_n,solid_phase_deg,\
             ball_free_re_m_per_n,ball_free_im_m_per_n,ball_free_mag_m_per_n,ball_free_phase_deg"
        );
        assert_eq!(header.len(), 13);
        assert_eq!(rows.len(), 491);
        let sc = Scenario::from_toml(&text).unwrap();
        let (damped, solid) = sc.bars().unwrap();
        let model = |b: BarModel| match b {
            BarModel::Lumped(bar) => Structure::Lumped(bar).modal_model().unwrap(),
            BarModel::Modal(m) => m,
        };
        let lines: Vec<f64> = rows.iter().map(|r| r[0]).collect();
        let md = sc.damper.ball_mass_kg;
        for (k, (m, stuck)) in [
            (model(solid), None),
            (model(damped), None),
            (model(damped), Some(md)),
        ]
        .into_iter()
        .enumerate()
        {
            let want = linear_frf(&m, stuck, Point::Force, Point::Cavity, &lines).unwrap();
            for (r, g) in rows.iter().zip(&want) {
                assert_eq!(r[1 + 4 * k], g.re, "{name} curve {k} at {} Hz", r[0]);
                assert_eq!(r[2 + 4 * k], g.im, "{name} curve {k} at {} Hz", r[0]);
                assert!((r[3 + 4 * k] - g.norm()).abs() <= 1e-15 * g.norm());
                assert!((r[4 + 4 * k] - g.arg().to_degrees()).abs() < 1e-12);
            }
        }
        let meta: serde_json::Value = serde_json::from_str(
            &fs::read_to_string(d.join(format!("{name}.csv.meta.json"))).unwrap(),
        )
        .unwrap();
        assert_eq!(meta["kind"], "frf");
        assert_eq!(meta["parameters"]["to"], "cavity");
        assert_eq!(meta["parameters"]["band_hz"][2], 10.0);
        for ext in ["png", "svg"] {
            let f = d.join(format!("{name}.{ext}"));
            assert!(fs::metadata(&f).unwrap().len() > 1000, "{name}.{ext}");
        }
    }
}

#[test]
fn frf_stepped_sine_and_tap_test_columns_and_a_cutting_scenario() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A soft stepped sine and tap: no impact, so both equal the ball-free receptance.
    let o = vibrobar_in(
        d,
        &[
            "frf",
            "--band-hz",
            "550:650:25",
            "--curves",
            "ball-free,stepped-sine,tap",
            "--force-n",
            "0.5",
            "--tap-force-n",
            "1",
            "--taps",
            "2",
            "--no-figure",
            "--out",
            "f.csv",
        ],
    );
    common::assert_ok(&o);
    let (header, rows) = table(&d.join("f.csv"));
    assert_eq!(
        header[5..].join(","),
        "stepped_sine_re_m_per_n,stepped_sine_im_m_per_n,stepped_sine_mag_m_per_n,\
         stepped_sine_phase_deg,stepped_sine_rms_m,stepped_sine_impacts_per_cycle,\
         tap_re_m_per_n,tap_im_m_per_n,tap_mag_m_per_n,tap_phase_deg,tap_coherence"
    );
    for r in &rows {
        let g = (r[1], r[2]);
        let e = |re: f64, im: f64| ((re - g.0).hypot(im - g.1)) / g.0.hypot(g.1);
        assert!(e(r[5], r[6]) < 1e-9, "{r:?}");
        assert_eq!(r[10], 0.0);
        assert!(e(r[11], r[12]) < 1e-6, "{r:?}");
        assert!((r[15] - 1.0).abs() < 1e-9);
    }
    assert!(!d.join("f.png").exists());
    let meta = fs::read_to_string(d.join("f.csv.meta.json")).unwrap();
    assert!(
        meta.contains("\"measure_periods\": 50") && meta.contains("\"taps\": 2"),
        "{meta}"
    );
    // A [cutting] scenario: the FRF is the bar's, out of the cut.
    fs::write(
        d.join("cut.toml"),
        format!("{MODES}[cutting]\ncoefficient_n_m2 = 2e9\nwidth_m = 1e-4\nfeed_m = 1e-4\nspindle_rpm = 5000\n"),
    )
    .unwrap();
    let o = vibrobar_in(
        d,
        &[
            "frf",
            "--scenario",
            "cut.toml",
            "--band-hz",
            "500:700:100",
            "--out",
            "c.csv",
        ],
    );
    common::assert_ok(&o);
}

#[test]
fn frf_bad_input_is_refused_naming_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let run = |extra: &[&str]| {
        let mut a = vec!["frf", "--out", "x.csv"];
        a.extend_from_slice(extra);
        vibrobar_in(d, &a)
    };
    for (band, want) in [
        ("500:400:1", "STOP"),
        ("0:400:1", "START"),
        ("-5:400:1", "START"),
        ("100:400:0", "STEP"),
        ("100:400:-1", "STEP"),
        ("nan:400:1", "finite"),
        ("100:inf:1", "finite"),
        ("100:400", "START:STOP:STEP"),
        ("100:x:1", "STOP must be a number"),
        ("1:1000000:0.001", "100000"),
    ] {
        let o = run(&["--band-hz", band]);
        assert_fails_with(&o, &["--band-hz", want]);
    }
    let ok = ["--band-hz", "500:600:50"];
    for (extra, want) in [
        (vec!["--curves", "tap", "--from", "cavity"], "--from cavity"),
        (
            vec!["--curves", "stepped-sine", "--to", "force"],
            "--to force",
        ),
        (vec!["--curves", "tap", "--taps", "0"], "--taps"),
        (
            vec!["--curves", "tap", "--tap-force-n", "nan"],
            "--tap-force-n",
        ),
        (
            vec!["--curves", "tap", "--tap-duration-s", "-1e-4"],
            "--tap-duration-s",
        ),
        (
            vec!["--curves", "tap", "--sample-rate-hz", "1000"],
            "--sample-rate-hz",
        ),
        (
            vec![
                "--curves",
                "tap",
                "--record-s",
                "1e6",
                "--sample-rate-hz",
                "1e6",
            ],
            "--record-s",
        ),
        (
            vec!["--curves", "stepped-sine", "--measure-periods", "0"],
            "--measure-periods",
        ),
        (
            vec!["--curves", "stepped-sine", "--force-n", "0"],
            "--force-n",
        ),
        (
            vec!["--curves", "stepped-sine", "--settle-s", "nan"],
            "--settle-s",
        ),
        (vec!["--gap-mm", "-1"], "--gap-mm"),
        (vec!["--curves", "wobble"], "wobble"),
    ] {
        let mut a: Vec<&str> = ok.to_vec();
        a.extend(extra);
        assert_fails_with(&run(&a), &[want]);
    }
    assert_eq!(names(d), Vec::<String>::new());
}

#[test]
fn frf_never_replaces_its_scenario() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fs::write(d.join("s.toml"), MODES).unwrap();
    let run = |sc: &str, out: &str| {
        vibrobar_in(
            d,
            &[
                "frf",
                "--scenario",
                sc,
                "--band-hz",
                "500:600:50",
                "--out",
                out,
            ],
        )
    };
    assert_fails_with(&run("s.toml", "s.toml"), &["is also an input"]);
    // The figure beside the CSV (f.png for f.csv) is an output too.
    fs::copy(d.join("s.toml"), d.join("f.png")).unwrap();
    assert_fails_with(&run("f.png", "f.csv"), &["is also an input"]);
    fs::copy(d.join("s.toml"), d.join("g.csv.meta.json")).unwrap();
    assert_fails_with(&run("g.csv.meta.json", "g.csv"), &["is also an input"]);
    for f in ["s.toml", "f.png", "g.csv.meta.json"] {
        assert_eq!(fs::read_to_string(d.join(f)).unwrap(), MODES);
    }
    assert_eq!(names(d), ["f.png", "g.csv.meta.json", "s.toml"]);
}

#[test]
fn sweep_in_hz_runs_both_bars_at_the_same_frequency() {
    use vibrobar_core::analysis::case::{run_one, Case};
    use vibrobar_core::analysis::{Batch, SweepPoint};
    use vibrobar_core::solver::Exact;
    use vibrobar_core::FrictionModel;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let o = vibrobar_in(
        d,
        &[
            "sweep",
            "--freqs-hz",
            "590:600:10",
            "--gap-mm",
            "0.1",
            "--duration",
            "0.2",
            "--out",
            "s.csv",
        ],
    );
    common::assert_ok(&o);
    let text = fs::read_to_string(d.join("s.csv")).unwrap();
    let rows: Vec<Vec<String>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    assert_eq!(rows.len(), 2);
    let mut sc = Scenario::paper();
    sc.run.settings.duration_s = 0.2;
    sc.damper.gap_m = 1e-4;
    let base = sc.base().unwrap();
    let settings = sc.settings();
    let solver = Exact::default();
    let batch = Batch::new(&base, &settings, &solver);
    for (row, f) in rows.iter().zip([590.0, 600.0]) {
        let w = 2.0 * std::f64::consts::PI * f;
        let (rd, rs) = (
            w / base.damped_bar.omega1_rad_s(),
            w / base.solid_bar.omega1_rad_s(),
        );
        // One Ω for both bars, though their own ω₁ differ.
        assert!(
            (rd * base.damped_bar.omega1_rad_s() - rs * base.solid_bar.omega1_rad_s()).abs()
                < 1e-12 * w
        );
        assert!((rd - rs).abs() > 1e-3);
        let solid = batch.solid(rs).unwrap().rms_m;
        let damped = run_one(
            &Case {
                system: base.damped_system(&SweepPoint {
                    ratio: rd,
                    gap_m: 1e-4,
                    friction: FrictionModel::None,
                    friction_force_n: None,
                }),
                init: base.init,
                sample_interval_s: None,
                energy_audit: false,
            },
            &settings,
            &solver,
        )
        .unwrap()
        .result
        .rms_m;
        assert_eq!(row[4].parse::<f64>().unwrap(), solid, "{f} Hz");
        assert_eq!(row[5].parse::<f64>().unwrap(), damped, "{f} Hz");
        assert!((row[0].parse::<f64>().unwrap() - rd).abs() < 1e-9);
    }
    let meta: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(d.join("s.csv.meta.json")).unwrap()).unwrap();
    assert_eq!(
        meta["parameters"]["frequencies_hz"],
        serde_json::json!([590.0, 600.0])
    );
    // Bad input names the flag; ratios and frequencies are exclusive.
    for (spec, want) in [
        ("0:600:10", "START"),
        ("600:500:10", "STOP"),
        ("500:600:0", "STEP"),
    ] {
        let o = vibrobar_in(d, &["sweep", "--freqs-hz", spec, "--out", "x.csv"]);
        assert_fails_with(&o, &["--freqs-hz", want]);
    }
    let o = vibrobar_in(
        d,
        &[
            "sweep",
            "--freqs-hz",
            "500:600:10",
            "--ratios",
            "1:1:1",
            "--out",
            "x.csv",
        ],
    );
    assert_fails_with(&o, &["--ratios"]);
}
