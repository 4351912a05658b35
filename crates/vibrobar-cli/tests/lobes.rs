//! `vibrobar lobes` end to end (issue #13 §4): the CSV (its header, the core's numbers to the
//! last bit), the metadata, the figure, every structure (lumped, `[beam]`, `[[modes]]`), and
//! bad input.

mod common;

use common::{assert_fails_with, names, s, vibrobar_in};
use std::fs;
use std::path::Path;
use vibrobar_core::analysis::lobes::Lobes;
use vibrobar_scenario::Scenario;

const CUT: &str = "[cutting]\ncoefficient_n_m2 = 2e9\nwidth_m = 1e-3\nfeed_m = 1e-4\nspindle_rpm = 5000\nforce_direction_factor = 0.9\n";
const MODES: &str = "[[modes]]\nfrequency_hz = 600\ndamping_ratio = 0.01\nmodal_mass_kg = 0.155\nshape_cavity = 0.9\n\
                     [[modes]]\nfrequency_hz = 3760\ndamping_ratio = 0.015\nmodal_mass_kg = 0.155\nshape_cavity = -0.4\n";

fn rows(p: &Path) -> Vec<Vec<f64>> {
    fs::read_to_string(p)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect()
}

#[test]
fn lobes_on_every_structure_write_the_core_numbers_metadata_and_a_figure() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (name, text, reference) in [
        ("lumped", CUT.to_string(), false),
        ("beam", format!("[beam]\nmodes = 3\n[beam.cavity_section]\nhole_diameter_m = 0.015\nlength_m = 0.017\n{CUT}"), false),
        ("modes", format!("{MODES}{CUT}"), true),
    ] {
        let sc_path = d.join(format!("{name}.toml"));
        fs::write(&sc_path, &text).unwrap();
        let out = d.join(format!("{name}.csv"));
        let o = vibrobar_in(
            d,
            &["lobes", "--scenario", s(&sc_path), "--rpm", "2000:40000:200", "--out", s(&out)],
        );
        common::assert_ok(&o);
        let csv = fs::read_to_string(&out).unwrap();
        assert!(csv.starts_with(
            "spindle_rpm,b_lim_m,chatter_frequency_hz,b_lim_ball_stuck_m,chatter_frequency_ball_stuck_hz,b_lim_solid_m"
        ));
        let got = rows(&out);
        assert_eq!(got.len(), 191);
        // The same numbers as the library's, bit for bit.
        let sc = Scenario::from_toml(&text).unwrap();
        let mut l = Lobes::new(&sc.lobe_spec().unwrap()).unwrap();
        for r in &got {
            let want = l.row(r[0]).unwrap();
            assert_eq!(
                r[1..7],
                [
                    want.ball_free.b_lim_m,
                    want.ball_free.chatter_frequency_hz,
                    want.ball_stuck.b_lim_m,
                    want.ball_stuck.chatter_frequency_hz,
                    want.solid.b_lim_m,
                    want.solid.chatter_frequency_hz
                ],
                "{name} at {} rpm",
                r[0]
            );
            assert_eq!(r[7], want.ball_free.lobe as f64);
        }
        let meta: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(d.join(format!("{name}.csv.meta.json"))).unwrap())
                .unwrap();
        assert_eq!(meta["kind"], "lobes");
        assert_eq!(meta["parameters"]["rpm_step"], 200.0);
        assert_eq!(meta["parameters"]["scenario"]["cutting"]["coefficient_n_m2"], 2e9);
        assert_eq!(
            meta["parameters"]["scenario"]["reference"] == "no_ball",
            reference,
            "{name}"
        );
        for ext in ["png", "svg"] {
            let f = d.join(format!("{name}.{ext}"));
            assert!(fs::metadata(&f).unwrap().len() > 1000, "{name}.{ext}");
        }
    }
    // --no-figure: CSV and metadata only.
    let o = vibrobar_in(
        d,
        &[
            "lobes",
            "--scenario",
            "lumped.toml",
            "--rpm",
            "3000:3000:1",
            "--no-figure",
            "--out",
            "n.csv",
        ],
    );
    common::assert_ok(&o);
    assert!(!d.join("n.png").exists() && d.join("n.csv.meta.json").exists());
}

#[test]
fn lobes_bad_input_is_refused_naming_the_flag_or_section() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fs::write(d.join("c.toml"), CUT).unwrap();
    fs::write(d.join("nocut.toml"), MODES).unwrap();
    let run = |sc: &str, rpm: &str, out: &str| {
        vibrobar_in(d, &["lobes", "--scenario", sc, "--rpm", rpm, "--out", out])
    };
    assert_fails_with(&run("nocut.toml", "1000:2000:100", "x.csv"), &["[cutting]"]);
    assert_fails_with(
        &run("c.toml", "2000:1000:100", "x.csv"),
        &["--rpm range is empty"],
    );
    assert_fails_with(
        &run("c.toml", "0.5:1000:100", "x.csv"),
        &["--rpm START = 0.5 rpm", "[1, 200000]"],
    );
    assert_fails_with(
        &run("c.toml", "1000:250000:1000", "x.csv"),
        &["--rpm STOP = 250000 rpm", "[1, 200000]"],
    );
    assert_fails_with(
        &run("c.toml", "1000:inf:1", "x.csv"),
        &["--rpm STOP must be a finite number"],
    );
    assert_fails_with(
        &run("c.toml", "1000:2000:0", "x.csv"),
        &["--rpm STEP = 0", "(0, ∞)"],
    );
    assert_fails_with(
        &run("c.toml", "1000:2000", "x.csv"),
        &["--rpm must be START:STOP:STEP"],
    );
    assert_fails_with(
        &run("c.toml", "1000:2000:1e-9", "x.csv"),
        &["--rpm speeds", "raise STEP"],
    );
    let bad_cut = CUT.replace("2e9", "-1");
    fs::write(d.join("b.toml"), bad_cut).unwrap();
    assert_fails_with(
        &run("b.toml", "1000:2000:100", "x.csv"),
        &["cutting.coefficient_n_m2"],
    );
    // Outputs that are the scenario: the CSV itself, or the figure beside it.
    assert_fails_with(
        &run("c.toml", "1000:2000:100", "c.toml"),
        &["is also an input"],
    );
    fs::copy(d.join("c.toml"), d.join("f.png")).unwrap();
    assert_fails_with(
        &run("f.png", "1000:2000:100", "f.csv"),
        &["is also an input"],
    );
    assert_eq!(fs::read_to_string(d.join("f.png")).unwrap(), CUT);
    assert_eq!(names(d), ["b.toml", "c.toml", "f.png", "nocut.toml"]);
}
