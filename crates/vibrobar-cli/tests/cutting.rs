//! Issue #13 on the command line: `run` and `ensemble` run a `[cutting]` scenario (the history
//! gains the cutting columns), every other command refuses it with the section named, and the
//! cutting flags check their ranges.

mod common;

use common::{stderr, vibrobar_in};
use std::fs;

const CUT: &str = "[bar]\nmass_kg = 0.1548\nstiffness_n_per_m = 2.2e6\n[damper]\ngap_m = 2e-5\n\
                   ball_mass_kg = 0.01\n[cutting]\ncoefficient_n_m2 = 2e9\nwidth_m = 5e-4\n\
                   feed_m = 1e-4\nspindle_rpm = 30000\n[initial]\nu_m = 5e-6\n\
                   [run]\nduration_s = 0.05\ndt_s = 1e-5\n";

#[test]
fn run_and_ensemble_take_the_cut_and_the_others_refuse_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fs::write(d.join("c.toml"), CUT).unwrap();
    let o = vibrobar_in(d, &["run", "--scenario", "c.toml", "--out", "h.csv"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = fs::read_to_string(d.join("h.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "t_s,u_m,du_m_s,v_m,dv_m_s,w_m,dw_m_s,chip_thickness_m,in_cut,cutting_force_n"
    );
    let in_cut: Vec<&str> = lines.map(|l| l.split(',').nth(8).unwrap()).collect();
    assert!(
        in_cut.contains(&"0") && in_cut.contains(&"1"),
        "the tool never left the cut"
    );
    let meta = fs::read_to_string(d.join("h.csv.meta.json")).unwrap();
    assert!(meta.contains("\"cutting\"") && meta.contains("chip_thickness_m"));
    let o = vibrobar_in(
        d,
        &[
            "ensemble",
            "--scenario",
            "c.toml",
            "--ratio",
            "1",
            "--gap-mm",
            "0.02",
            "--members",
            "2",
            "--out",
            "e.csv",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(fs::read_to_string(d.join("e.csv.meta.json"))
        .unwrap()
        .contains("coefficient_n_m2"));
    let refused: [&[&str]; 7] = [
        &["sweep", "--ratios", "1:1:1", "--out", "x.csv"],
        &[
            "map",
            "--ratios",
            "1:1:1",
            "--gaps-mm",
            "0.1:0.1:0.1",
            "--out",
            "x.csv",
        ],
        &[
            "poincare", "--ratio", "1", "--gap-mm", "0.1", "--out", "x.csv",
        ],
        &[
            "bifurcation",
            "--param",
            "ratio",
            "--values",
            "1:1:1",
            "--gap-mm",
            "0.1",
            "--out",
            "x.csv",
        ],
        &[
            "placement",
            "--positions-mm",
            "100:100:1",
            "--gaps-mm",
            "0.1:0.1:0.1",
            "--ratios",
            "1:1:1",
            "--out",
            "x.csv",
        ],
        &["lyapunov", "--ratio", "1", "--gap-mm", "0.1"],
        &["bench"],
    ];
    for args in refused {
        let mut a: Vec<&str> = args.to_vec();
        a.extend(["--scenario", "c.toml"]);
        let o = vibrobar_in(d, &a);
        assert!(!o.status.success(), "{a:?} ran a cutting scenario");
        let e = stderr(&o);
        assert!(
            e.contains(&format!(
                "vibrobar {} does not support the [cutting] section",
                a[0]
            )),
            "{a:?}: {e}"
        );
        assert!(!d.join("x.csv").exists());
    }
}

#[test]
fn cutting_flags_check_their_ranges_and_need_the_section() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fs::write(d.join("c.toml"), CUT).unwrap();
    for (flag, v, want) in [
        ("--width-mm", "0", "--width-mm"),
        ("--width-mm", "-1", "--width-mm"),
        ("--spindle-rpm", "0.5", "--spindle-rpm"),
        ("--spindle-rpm", "300000", "--spindle-rpm"),
    ] {
        let o = vibrobar_in(
            d,
            &["run", "--scenario", "c.toml", flag, v, "--out", "h.csv"],
        );
        assert!(!o.status.success());
        assert!(stderr(&o).contains(want), "{flag} {v}: {}", stderr(&o));
    }
    let o = vibrobar_in(d, &["run", "--spindle-rpm", "5000", "--out", "h.csv"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("[cutting]"), "{}", stderr(&o));
    let o = vibrobar_in(
        d,
        &[
            "run",
            "--scenario",
            "c.toml",
            "--solver",
            "rk4",
            "--out",
            "h.csv",
        ],
    );
    assert!(
        stderr(&o).contains("[cutting] runs with the exact solver only"),
        "{}",
        stderr(&o)
    );
    // A bad value in the file names the field and its range.
    fs::write(
        d.join("bad.toml"),
        CUT.replace("spindle_rpm = 30000", "spindle_rpm = 0"),
    )
    .unwrap();
    let o = vibrobar_in(d, &["run", "--scenario", "bad.toml", "--out", "h.csv"]);
    assert!(stderr(&o).contains("cutting.spindle_rpm"), "{}", stderr(&o));
    let o = vibrobar_in(
        d,
        &[
            "run",
            "--scenario",
            "c.toml",
            "--width-mm",
            "0.3",
            "--spindle-rpm",
            "20000",
            "--out",
            "h.csv",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
}
