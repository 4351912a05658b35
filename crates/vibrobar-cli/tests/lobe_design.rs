//! `vibrobar lobe-design` end to end (issue #14 §3): the core's rows, the optimum file and the
//! figure; shards merged and an interrupted run resumed, both to the same bytes; the beam
//! variant; bad input named.

mod common;

use common::{assert_fails_with, assert_ok, s, vibrobar_in};
use std::fs;
use std::path::{Path, PathBuf};
use vibrobar_core::analysis::batch::Runner;
use vibrobar_core::analysis::lobe_design::{lobe_design, optimum, DesignAxis, DesignGrid};
use vibrobar_core::analysis::time_domain::{linear_at, BarKind, Disturbance};
use vibrobar_core::SimError;
use vibrobar_io::csv::{lobe_design_schema, lobe_design_values};
use vibrobar_scenario::Scenario;

/// A one-mode bar (600 Hz) as both bars, the paper's ball, short windows.
const SC: &str = "[bar]\nmass_kg = 0.1548\nstiffness_n_per_m = 2.2e6\ndamping_ratio = 0.01\n\
[solid_bar]\nmass_kg = 0.1548\nstiffness_n_per_m = 2.2e6\ndamping_ratio = 0.01\n\
[damper]\ngap_m = 1e-4\nball_mass_kg = 0.026\n\
[cutting]\ncoefficient_n_m2 = 2e9\nwidth_m = 1e-5\nfeed_m = 1e-4\nspindle_rpm = 5000\n\
[time_domain]\nsettle_revs = 10\njudge_revs = 20\nmonotonic_checks = 2\n";

const RPM: &str = "5000:7000:2000";

fn args<'a>(sc: &'a str, out: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut v = vec![
        "lobe-design",
        "--scenario",
        sc,
        "--rpm",
        RPM,
        "--gaps-mm",
        "0.05:0.2:0.15",
        "--ball-masses-g",
        "10:30:20",
        "--out",
        out,
    ];
    v.extend_from_slice(extra);
    v
}

fn journal_of(out: &Path) -> PathBuf {
    PathBuf::from(format!("{}.journal", s(out)))
}

fn setup() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let sc = dir.path().join("s.toml");
    fs::write(&sc, SC).unwrap();
    (dir, sc)
}

#[test]
fn lobe_design_writes_the_core_rows_the_optimum_and_a_figure() {
    let (dir, sc) = setup();
    let d = dir.path();
    let out = d.join("d.csv");
    assert_ok(&vibrobar_in(d, &args(s(&sc), s(&out), &[])));
    let csv = fs::read_to_string(&out).unwrap();
    // The core's rows, formatted by the one schema.
    let p = Scenario::from_toml(SC).unwrap();
    let spec = vibrobar_core::analysis::lobe_design::LobeDesignSpec {
        base: p.cut_problem().unwrap(),
        beam: None,
        axis: DesignAxis::BallMass,
    };
    let grid = DesignGrid::new(DesignAxis::BallMass, vec![5e-5, 2e-4], vec![0.01, 0.03]).unwrap();
    let (_, rows) = lobe_design(&spec, &grid, &[5000.0, 7000.0], &Runner::default()).unwrap();
    let schema = lobe_design_schema(DesignAxis::BallMass);
    let mut want = schema.header() + "\n";
    for r in &rows {
        want += &(schema.format(&lobe_design_values(r)) + "\n");
    }
    assert_eq!(csv, want);
    assert!(csv.starts_with("gap_m,ball_mass_kg,worst_width_m,worst_rpm,mean_width_m"));
    let best = optimum(&rows).unwrap();
    assert_eq!(
        fs::read_to_string(d.join("d.optimum.csv")).unwrap(),
        format!(
            "{}\n{}\n",
            schema.header(),
            schema.format(&lobe_design_values(best))
        )
    );
    for f in ["d.png", "d.svg", "d.csv.meta.json"] {
        assert!(d.join(f).exists(), "{f}");
    }
}

#[test]
fn shards_merged_equal_the_unsharded_study() {
    let (dir, sc) = setup();
    let d = dir.path();
    let full = d.join("full.csv");
    assert_ok(&vibrobar_in(d, &args(s(&sc), s(&full), &[])));
    let mut shards = Vec::new();
    for k in 1..=3 {
        let o = d.join(format!("s{k}.csv"));
        let shard = format!("{k}/3");
        assert_ok(&vibrobar_in(
            d,
            &args(s(&sc), s(&o), &["--shard", shard.as_str()]),
        ));
        assert!(!d.join(format!("s{k}.optimum.csv")).exists());
        shards.push(o);
    }
    let merged = d.join("m.csv");
    assert_ok(&vibrobar_in(
        d,
        &[
            "merge",
            "--out",
            s(&merged),
            s(&shards[2]),
            s(&shards[0]),
            s(&shards[1]),
        ],
    ));
    assert_eq!(fs::read(&merged).unwrap(), fs::read(&full).unwrap());
    assert_eq!(
        fs::read(d.join("m.optimum.csv")).unwrap(),
        fs::read(d.join("full.optimum.csv")).unwrap()
    );
    assert!(d.join("m.png").exists());
}

#[test]
fn resume_after_an_interruption_is_byte_identical() {
    let (dir, sc) = setup();
    let d = dir.path();
    let full = d.join("full.csv");
    assert_ok(&vibrobar_in(d, &args(s(&sc), s(&full), &["--no-figure"])));
    let meta: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(d.join("full.csv.meta.json")).unwrap()).unwrap();
    let fingerprint = meta["fingerprint"].as_str().unwrap();
    let text = fs::read_to_string(&full).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let rows: Vec<&str> = lines.collect();
    // A journal as a killed run leaves it: rows in completion order, a torn last line.
    let out = d.join("part.csv");
    let mut j = format!("# vibrobar journal v1 fingerprint={fingerprint}\nindex,{header}\n");
    for i in [3usize, 0] {
        j.push_str(&format!("{i},{}\n", rows[i]));
    }
    j.push_str(&format!("2,{}", &rows[2][..rows[2].len() / 2]));
    fs::write(journal_of(&out), j).unwrap();
    assert_fails_with(
        &vibrobar_in(d, &args(s(&sc), s(&out), &["--no-figure"])),
        &["--resume"],
    );
    assert!(!out.exists());
    assert_ok(&vibrobar_in(
        d,
        &args(s(&sc), s(&out), &["--no-figure", "--resume"]),
    ));
    assert_eq!(fs::read(&out).unwrap(), fs::read(&full).unwrap());
    assert!(!journal_of(&out).exists());
}

/// Gap × cavity position on a `[beam]`: while the judge refuses modal bars the command says so
/// and leaves no file; once it runs them, the command writes the core's rows.
#[test]
fn a_beam_study_runs_or_is_refused_as_the_judge_is() {
    let beam = "[beam]\nmodes = 1\n[damper]\ngap_m = 1e-4\n\
[cutting]\ncoefficient_n_m2 = 2e9\nwidth_m = 1e-5\nfeed_m = 1e-4\nspindle_rpm = 5000\n\
[time_domain]\nsettle_revs = 10\njudge_revs = 20\nmonotonic_checks = 0\n";
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fs::write(d.join("b.toml"), beam).unwrap();
    let a = [
        "lobe-design",
        "--scenario",
        "b.toml",
        "--rpm",
        "5000:5000:1",
        "--gaps-mm",
        "0.1:0.1:0.1",
        "--positions-mm",
        "150:150:1",
        "--no-figure",
        "--out",
        "b.csv",
    ];
    let o = vibrobar_in(d, &a);
    let p = Scenario::from_toml(beam).unwrap().cut_problem().unwrap();
    let lin = linear_at(&p, &[5000.0]).unwrap()[0];
    let probe = p.judge(
        BarKind::Solid,
        Disturbance::Large,
        0.5 * lin.b_lim_solid_m,
        5000.0,
        lin.omega_solid_rad_s,
    );
    match probe {
        Err(SimError::Unsupported(why)) => {
            assert_fails_with(&o, &["not supported yet"]);
            assert!(why.contains("not supported yet"));
            assert!(!d.join("b.csv").exists() && !d.join("b.csv.journal").exists());
        }
        other => {
            other.unwrap();
            assert_ok(&o);
            let csv = fs::read_to_string(d.join("b.csv")).unwrap();
            assert!(csv.starts_with("gap_m,position_m,worst_width_m"), "{csv}");
            assert_eq!(csv.lines().count(), 2);
        }
    }
}

#[test]
fn bad_input_names_the_flag_and_its_range() {
    let (dir, sc) = setup();
    let d = dir.path();
    let run = |flag: &str, value: &str| {
        let mut v = args(s(&sc), "x.csv", &[]);
        let i = v.iter().position(|x| *x == flag).unwrap();
        v[i + 1] = value;
        vibrobar_in(d, &v)
    };
    assert_fails_with(
        &run("--ball-masses-g", "0:10:10"),
        &["--ball-masses-g", "(0, ∞)"],
    );
    assert_fails_with(&run("--gaps-mm", "0.2:0.1:0.1"), &["--gaps-mm", "STOP"]);
    assert_fails_with(&run("--gaps-mm", "0.1:inf:0.1"), &["--gaps-mm", "finite"]);
    assert_fails_with(&run("--rpm", "0:1000:500"), &["--rpm"]);
    assert_fails_with(&run("--rpm", "1000:300000:100000"), &["--rpm", "200000"]);
    // Positions need a beam.
    let mut v = args(s(&sc), "x.csv", &[]);
    let i = v.iter().position(|x| *x == "--ball-masses-g").unwrap();
    v[i] = "--positions-mm";
    assert_fails_with(&vibrobar_in(d, &v), &["--positions-mm", "[beam]"]);
    // Exactly one design axis.
    let both = args(s(&sc), "x.csv", &["--positions-mm", "100:100:1"]);
    assert_fails_with(&vibrobar_in(d, &both), &["--positions-mm"]);
    let bad = SC.replace("judge_revs = 20", "judge_revs = 2");
    fs::write(d.join("bad.toml"), bad).unwrap();
    assert_fails_with(
        &vibrobar_in(d, &args("bad.toml", "x.csv", &[])),
        &["time_domain.judge_revs"],
    );
    assert!(!d.join("x.csv").exists() && !d.join("x.csv.journal").exists());
}
