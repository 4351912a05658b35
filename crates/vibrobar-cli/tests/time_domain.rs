//! `vibrobar width-diagram` and `vibrobar lobes --time-domain` end to end (issue #14): headers,
//! the core's numbers, sharding and merge to the same bytes, resume, figures, bad input.

mod common;

use common::{assert_fails_with, assert_ok, s, vibrobar_in};
use std::fs;
use vibrobar_core::analysis::batch::Runner;
use vibrobar_core::analysis::time_domain::{linear_at, td_lobe_row, width_diagram};
use vibrobar_scenario::Scenario;

/// A one-mode bar (600 Hz), a ball far out of reach, short windows.
const SC: &str = "[bar]\nmass_kg = 0.1548\nstiffness_n_per_m = 2.2e6\ndamping_ratio = 0.01\n\
[solid_bar]\nmass_kg = 0.1548\nstiffness_n_per_m = 2.2e6\ndamping_ratio = 0.01\n\
[damper]\ngap_m = 1e-4\nball_mass_kg = 0.026\n\
[cutting]\ncoefficient_n_m2 = 2e9\nwidth_m = 1e-5\nfeed_m = 1e-4\nspindle_rpm = 5000\n\
[time_domain]\nsettle_revs = 10\njudge_revs = 20\nmonotonic_checks = 2\n";

#[test]
fn width_diagram_writes_the_core_rows_shards_merge_and_a_figure() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sc_path = d.join("s.toml");
    fs::write(&sc_path, SC).unwrap();
    let out = d.join("d.csv");
    let args = [
        "width-diagram",
        "--scenario",
        s(&sc_path),
        "--rpm",
        "5000",
        "--widths-mm",
        "0.02:0.1:0.04",
    ];
    let o = vibrobar_in(d, &[&args[..], &["--out", s(&out)]].concat());
    assert_ok(&o);
    let csv = fs::read_to_string(&out).unwrap();
    assert!(csv.starts_with(
        "width_m,disturbance,bar,peak_to_peak_m,out_of_cut_fraction,impacts_per_rev,regime,static_deflection_m"
    ));
    assert_eq!(csv.lines().count(), 1 + 3 * 4);
    assert!(
        d.join("d.png").exists() && d.join("d.svg").exists() && d.join("d.csv.meta.json").exists()
    );
    // The core's numbers.
    let sc = Scenario::from_toml(SC).unwrap();
    let p = sc.cut_problem().unwrap();
    let rows = width_diagram(&p, 5000.0, &[2e-5, 6e-5, 1e-4], &Runner::default()).unwrap();
    for (line, r) in csv.lines().skip(1).zip(&rows) {
        let f: Vec<&str> = line.split(',').collect();
        assert_eq!(f[1], r.disturbance.as_str());
        assert_eq!(f[2], r.bar.as_str());
        assert_eq!(f[3].parse::<f64>().unwrap(), r.judged.peak_to_peak_m);
        assert_eq!(f[6], r.judged.regime.as_str());
    }
    // Two shards merged: the same bytes.
    let mut shards = Vec::new();
    for k in 1..=2 {
        let o_k = d.join(format!("d{k}.csv"));
        let shard = format!("{k}/2");
        assert_ok(&vibrobar_in(
            d,
            &[&args[..], &["--shard", &shard, "--out", s(&o_k)]].concat(),
        ));
        shards.push(o_k);
    }
    let merged = d.join("m.csv");
    assert_ok(&vibrobar_in(
        d,
        &["merge", "--out", s(&merged), s(&shards[0]), s(&shards[1])],
    ));
    assert_eq!(fs::read(&merged).unwrap(), fs::read(&out).unwrap());
    assert!(d.join("m.png").exists());
}

#[test]
fn time_domain_lobes_write_the_core_rows_and_a_figure() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sc_path = d.join("s.toml");
    fs::write(&sc_path, SC).unwrap();
    let out = d.join("t.csv");
    let o = vibrobar_in(
        d,
        &[
            "lobes",
            "--time-domain",
            "--scenario",
            s(&sc_path),
            "--rpm",
            "4000:6000:2000",
            "--out",
            s(&out),
        ],
    );
    assert_ok(&o);
    let csv = fs::read_to_string(&out).unwrap();
    assert!(csv.starts_with(
        "spindle_rpm,b_lim_m,b_lim_solid_m,b_solid_small_m,b_solid_large_m,b_damped_small_m,b_damped_large_m,event_limit_runs"
    ));
    let sc = Scenario::from_toml(SC).unwrap();
    let p = sc.cut_problem().unwrap();
    let lin = linear_at(&p, &[4000.0, 6000.0]).unwrap();
    for (i, line) in csv.lines().skip(1).enumerate() {
        let f: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        let r = td_lobe_row(&p, f[0], &lin[i]).unwrap();
        let want: Vec<f64> = r.searches.iter().map(|s| s.width_m).collect();
        assert_eq!(f[3..7], want[..]);
        assert_eq!(f[2], lin[i].b_lim_solid_m);
    }
    assert!(d.join("t.png").exists());
}

#[test]
fn bad_input_names_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sc_path = d.join("s.toml");
    fs::write(&sc_path, SC).unwrap();
    let out = d.join("x.csv");
    let wd = |w: &str, rpm: &str| {
        vibrobar_in(
            d,
            &[
                "width-diagram",
                "--scenario",
                s(&sc_path),
                "--rpm",
                rpm,
                "--widths-mm",
                w,
                "--out",
                s(&out),
            ],
        )
    };
    assert_fails_with(&wd("0.1:0.05:0.01", "5000"), &["--widths-mm", "empty"]);
    assert_fails_with(&wd("0.1:inf:0.01", "5000"), &["--widths-mm"]);
    assert_fails_with(&wd("0.01:0.05:0.01", "0"), &["--rpm"]);
    for (line, field) in [
        (
            "large_disturbance_m = -1e-6",
            "time_domain.large_disturbance_m",
        ),
        ("vibration_limit_m = 0", "time_domain.vibration_limit_m"),
        (
            "growth_tolerance_per_rev = -1",
            "time_domain.growth_tolerance_per_rev",
        ),
        (
            "bisection_tolerance = 0.7",
            "time_domain.bisection_tolerance",
        ),
    ] {
        let bad = d.join("bad.toml");
        fs::write(
            &bad,
            SC.replace("[time_domain]\n", &format!("[time_domain]\n{line}\n")),
        )
        .unwrap();
        let o = vibrobar_in(
            d,
            &[
                "lobes",
                "--time-domain",
                "--scenario",
                s(&bad),
                "--rpm",
                "4000:6000:2000",
                "--out",
                s(&out),
            ],
        );
        assert_fails_with(&o, &[field]);
    }
    // Windows shorter than a few delays.
    let short = d.join("short.toml");
    fs::write(&short, SC.replace("judge_revs = 20", "judge_revs = 3")).unwrap();
    let o = vibrobar_in(
        d,
        &[
            "lobes",
            "--time-domain",
            "--scenario",
            s(&short),
            "--rpm",
            "4000:6000:2000",
            "--out",
            s(&out),
        ],
    );
    assert_fails_with(&o, &["time_domain.judge_revs", "[10"]);
    // Without [cutting]: the section is named.
    let plain = d.join("plain.toml");
    fs::write(&plain, "[bar]\nmass_kg = 0.2\n").unwrap();
    let o = vibrobar_in(
        d,
        &[
            "width-diagram",
            "--scenario",
            s(&plain),
            "--rpm",
            "5000",
            "--widths-mm",
            "0.01:0.02:0.01",
            "--out",
            s(&out),
        ],
    );
    assert_fails_with(&o, &["[cutting]"]);
    assert!(!out.exists());
}
