//! Issue #13 on the command line: `vibrobar run` on a `[cutting]` scenario with the compliant
//! contact law (`[contact] law = "hertz"`) runs and writes the cutting columns.

mod common;

use common::{stderr, vibrobar_in};
use std::fs;

const CUT_HERTZ: &str = "[bar]\nmass_kg = 0.1548\nstiffness_n_per_m = 2.2e6\n[damper]\n\
                         gap_m = 2e-5\nball_mass_kg = 0.01\n[contact]\nlaw = \"hertz\"\n\
                         [cutting]\ncoefficient_n_m2 = 2e9\nwidth_m = 5e-4\nfeed_m = 1e-4\n\
                         spindle_rpm = 30000\n[initial]\nu_m = 5e-6\n\
                         [run]\nduration_s = 0.05\ndt_s = 1e-5\n";

#[test]
fn run_takes_a_cut_with_the_hertz_contact_law() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fs::write(d.join("c.toml"), CUT_HERTZ).unwrap();
    let o = vibrobar_in(d, &["run", "--scenario", "c.toml", "--out", "h.csv"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = fs::read_to_string(d.join("h.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "t_s,u_m,du_m_s,v_m,dv_m_s,w_m,dw_m_s,chip_thickness_m,in_cut,cutting_force_n"
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert!(rows.len() > 400);
    // The tool leaves the cut and comes back; out of it the force is 0, in it positive.
    assert!(rows.iter().any(|r| r[8] == 0.0) && rows.iter().any(|r| r[8] == 1.0));
    for r in &rows {
        assert!(r.iter().all(|x| x.is_finite()));
        if r[8] == 0.0 {
            assert!(r[7] <= 1e-12 && r[9] == 0.0, "{r:?}");
        } else {
            assert!(r[7] >= -1e-12 && r[9] >= 0.0, "{r:?}");
        }
    }
    // The compliant law: the ball sinks into a wall (|w| beyond the half gap) at some samples.
    let lg = 1e-5;
    let deepest = rows
        .iter()
        .map(|r| r[5].abs() - lg)
        .fold(f64::MIN, f64::max);
    assert!(deepest > 1e-8 && deepest < 1e-5, "{deepest}");
    let meta = fs::read_to_string(d.join("h.csv.meta.json")).unwrap();
    assert!(
        meta.contains("\"cutting\"") && meta.contains("hertz"),
        "{meta}"
    );
}

/// A `[beam]` (modal bar) with the hertz law and a cut: the section is accepted by `run`,
/// `lobes --time-domain`, `width-diagram` and `lobe-design` (issue #13: the modal cutting run's
/// contact phase), `run` writing the cutting columns with the ball inside a wall at some samples.
const BEAM_HERTZ: &str = "[beam]\nmodes = 2\n[damper]\ngap_m = 2e-5\nball_mass_kg = 0.01\n\
                          [contact]\nlaw = \"hertz\"\n\
                          [cutting]\ncoefficient_n_m2 = 2e9\nwidth_m = 5e-4\nfeed_m = 1e-4\n\
                          spindle_rpm = 20000\n[initial]\nu_m = 1.5e-4\n\
                          [time_domain]\nsettle_revs = 10\njudge_revs = 20\nmonotonic_checks = 0\n\
                          [run]\nduration_s = 0.02\ndt_s = 1e-5\n";

#[test]
fn a_beam_with_the_hertz_law_takes_a_cut_in_every_cutting_command() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fs::write(d.join("b.toml"), BEAM_HERTZ).unwrap();
    let o = vibrobar_in(d, &["run", "--scenario", "b.toml", "--out", "h.csv"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = fs::read_to_string(d.join("h.csv")).unwrap();
    let rows: Vec<Vec<f64>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    let ncol = text.lines().next().unwrap().split(',').count();
    let w = text
        .lines()
        .next()
        .unwrap()
        .split(',')
        .position(|c| c == "w_m")
        .unwrap();
    let in_cut = ncol - 2;
    assert!(rows.len() > 150);
    assert!(rows.iter().any(|r| r[in_cut] == 0.0) && rows.iter().any(|r| r[in_cut] == 1.0));
    assert!(rows.iter().all(|r| r.iter().all(|x| x.is_finite())));
    let deepest = rows
        .iter()
        .map(|r| r[w].abs() - 1e-5)
        .fold(f64::MIN, f64::max);
    assert!(deepest > 1e-9 && deepest < 1e-5, "{deepest}");
    for a in [
        &[
            "lobes",
            "--time-domain",
            "--scenario",
            "b.toml",
            "--rpm",
            "20000:20000:1",
            "--no-figure",
            "--out",
            "t.csv",
        ][..],
        &[
            "width-diagram",
            "--scenario",
            "b.toml",
            "--rpm",
            "20000",
            "--widths-mm",
            "0.5:0.5:0.1",
            "--no-figure",
            "--out",
            "w.csv",
        ][..],
        &[
            "lobe-design",
            "--scenario",
            "b.toml",
            "--rpm",
            "20000:20000:1",
            "--gaps-mm",
            "0.02:0.02:0.1",
            "--ball-masses-g",
            "10:10:1",
            "--no-figure",
            "--out",
            "l.csv",
        ][..],
    ] {
        let o = vibrobar_in(d, a);
        assert!(o.status.success(), "{}: {}", a[0], stderr(&o));
        assert!(d.join(a[a.len() - 1]).exists(), "{}", a[0]);
    }
}
