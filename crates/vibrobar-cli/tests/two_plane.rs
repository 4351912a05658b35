//! The generated two-plane document (`vibrobar two-plane --quick`): its sections and tables,
//! that the table of every point is written beside it with finite numbers, that with the force
//! along the hole on frictionless walls the two models give the same answers, and that bad
//! flags are refused before anything is written.

mod common;

use common::{assert_fails_with, s, vibrobar, vibrobar_ok};
use std::fs;

#[test]
fn quick_document_has_its_tables_and_the_force_along_the_hole_agrees_with_one_plane() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("docs/two-plane.md");
    vibrobar_ok(&["two-plane", "--quick", "--out", s(&out)]);
    let doc = fs::read_to_string(&out).unwrap();
    for h in [
        "# One plane or two: the ball in a hole across a round bar",
        "## The model",
        "## The exact solver against the reference",
        "## The beam referred to the tip",
        "## One plane against two planes, frictionless walls",
        "## One plane against two planes, frictional walls",
        "## Where to drill the hole: hole angle × axial gap",
        "## How tight a hole: radial clearance × axial gap",
        "## Which of the paper's conclusions survive",
        "| hole | gap | r | one plane | 0° | 63.4° |",
    ] {
        assert!(doc.contains(h), "missing {h:?}");
    }
    assert!(!doc.contains("NaN") && !doc.contains("inf"));
    assert!(!doc.contains("-0 "), "a negative zero in a cell");
    let csv = fs::read_to_string(d.path().join("docs/two-plane/points.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    // 2 wall laws × 2 holes × 2 gaps × 1 ratio × 2 forces, the two 2 × 2 maps and the beam's
    // 2 holes × 2 gaps × 2 forces; two models each; and the reference solver's check at the four
    // frictionless points at 63.4°.
    assert_eq!(rows.len(), 2 * (16 + 4 + 4 + 8) + 4);
    assert_eq!(rows.iter().filter(|r| r[0] == "beam").count(), 16);
    for r in &rows {
        assert_eq!(r.len(), 17);
        let r = &r[1..];
        for v in &r[9..] {
            assert!(v.parse::<f64>().unwrap().is_finite(), "{r:?}");
        }
        // The exact solver where the planes decouple, the reference one with friction.
        let expected = match (r[0], r[7]) {
            (_, "one-plane") | ("frictionless", _) => &["exact", "reference"][..],
            _ => &["reference"][..],
        };
        assert!(expected.contains(&r[8]), "{r:?}");
    }
    let checks = rows
        .iter()
        .filter(|r| r[1] == "frictionless" && r[8] == "two-plane" && r[9] == "reference")
        .count();
    assert_eq!(checks, 4);
    // Frictionless walls with the force along the hole: two planes = one plane, member by
    // member, so the means and ranges agree.
    let along: Vec<Vec<&str>> = rows
        .iter()
        .filter(|r| r[0] == "lumped" && r[1] == "frictionless" && r[7] == "0")
        .map(|r| r[1..].to_vec())
        .collect();
    assert_eq!(along.len(), 8);
    for pair in along.chunks(2) {
        let (two, one) = (&pair[0], &pair[1]);
        assert_eq!((two[7], one[7]), ("two-plane", "one-plane"));
        for k in 9..13 {
            let (a, b): (f64, f64) = (two[k].parse().unwrap(), one[k].parse().unwrap());
            assert!((a - b).abs() < 0.01, "{two:?} against {one:?}");
        }
    }
}

#[test]
fn bad_flags_are_refused_and_nothing_is_written() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("two-plane.md");
    let o = vibrobar(&["two-plane", "--members", "0", "--out", s(&out)]);
    assert_fails_with(&o, &["--members"]);
    let o = vibrobar(&["two-plane", "--duration", "-1", "--out", s(&out)]);
    assert_fails_with(&o, &["--duration"]);
    let txt = d.path().join("two-plane.txt");
    let o = vibrobar(&["two-plane", "--quick", "--out", s(&txt)]);
    assert_fails_with(&o, &["--out", ".md"]);
    assert!(fs::read_dir(d.path()).unwrap().next().is_none());
}

const TWO_PLANE: &str = "[damper]\ngap_m = 1.0e-3\n\n[run]\nduration_s = 0.5\n\n[two_plane]\nhole_diameter_m = 0.0151\nforce_ratio = 2.0\n";

/// Rows of a two-plane sweep CSV, by column name.
fn sweep_rows(csv: &str) -> Vec<std::collections::HashMap<String, String>> {
    let mut lines = csv.lines();
    let head: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    lines
        .map(|l| {
            head.iter()
                .cloned()
                .zip(l.split(',').map(String::from))
                .collect()
        })
        .collect()
}

#[test]
fn a_two_plane_scenario_sweeps_ensembles_beside_the_one_plane_model() {
    let d = tempfile::tempdir().unwrap();
    let sc = d.path().join("tp.toml");
    fs::write(&sc, TWO_PLANE).unwrap();
    let out = d.path().join("out.csv");
    vibrobar_ok(&[
        "sweep",
        "--scenario",
        s(&sc),
        "--ratios",
        "0.97:1.03:0.03",
        "--gap-mm",
        "0.1",
        "--gap-mm",
        "1.0",
        "--out",
        s(&out),
    ]);
    let rows = sweep_rows(&fs::read_to_string(&out).unwrap());
    assert_eq!(rows.len(), 6);
    let num = |r: &std::collections::HashMap<String, String>, k: &str| -> f64 {
        r[k].parse().unwrap_or_else(|_| panic!("{k} = {}", r[k]))
    };
    for r in &rows {
        assert_eq!(r.len(), 19);
        assert_eq!(r["solver"], "exact");
        assert_eq!(r["members"], "8");
        for (k, v) in r {
            if k != "solver" {
                assert!(v.parse::<f64>().unwrap().is_finite(), "{k} = {v}");
            }
        }
        assert!(num(r, "rms_along_force_min_m") <= num(r, "rms_along_force_mean_m"));
        assert!(num(r, "rms_along_force_mean_m") <= num(r, "rms_along_force_max_m"));
    }
    // At resonance with the 1 mm gap and a tight hole, the plane across the hole damps: two
    // planes reduce the vibration by far more than the one-plane model says.
    let res = rows
        .iter()
        .find(|r| r["axial_gap_m"] == "0.001" && r["ratio"] == "1")
        .unwrap();
    assert!(
        num(res, "reduction_mean_pct") > num(res, "one_plane_reduction_mean_pct") + 20.0,
        "{res:?}"
    );
    // With friction on the walls the reference solver runs, and says so.
    let rough = d.path().join("rough.toml");
    fs::write(
        &rough,
        format!("{TWO_PLANE}friction_static = 0.3\nfriction_kinetic = 0.2\n")
            .replace("duration_s = 0.5", "duration_s = 0.01"),
    )
    .unwrap();
    vibrobar_ok(&[
        "sweep",
        "--scenario",
        s(&rough),
        "--ratios",
        "1:1:0.1",
        "--out",
        s(&out),
    ]);
    let rows = sweep_rows(&fs::read_to_string(&out).unwrap());
    assert!(rows.iter().all(|r| r["solver"] == "reference"), "{rows:?}");
}

#[test]
fn bad_two_plane_scenarios_name_the_field_and_other_commands_refuse_them() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("out.csv");
    for (extra, words) in [
        (
            "hole_diameter_m = 0.012\n",
            &["[two_plane] hole_diameter_m"][..],
        ),
        (
            "friction_static = 1.0\n",
            &["[two_plane] friction_static"][..],
        ),
        (
            "friction_static = 0.2\nfriction_kinetic = 0.3\n",
            &["[two_plane] friction_kinetic"][..],
        ),
        (
            "hole_angle_deg = nan\n",
            &["[two_plane] hole_angle_deg"][..],
        ),
        (
            "force_angle_deg = 60.0\n",
            &["force_angle_deg", "force_ratio"][..],
        ),
        (
            "solver = \"rk4\"\n",
            &["[two_plane] solver", "reference"][..],
        ),
        ("members = 0\n", &["[two_plane] members"][..]),
        ("colour = 1\n", &["colour"][..]),
        (
            "friction_static = 0.3\nsolver = \"exact\"\n",
            &["exact", "frictionless walls"][..],
        ),
    ] {
        let sc = d.path().join("bad.toml");
        let base = TWO_PLANE.replace("hole_diameter_m = 0.0151\n", "");
        fs::write(&sc, format!("{base}{extra}")).unwrap();
        let o = vibrobar(&["sweep", "--scenario", s(&sc), "--out", s(&out)]);
        assert_fails_with(&o, words);
        assert!(!out.exists(), "{extra}: an output was written");
    }
    let sc = d.path().join("tp.toml");
    fs::write(&sc, TWO_PLANE).unwrap();
    let o = vibrobar(&[
        "bifurcation",
        "--scenario",
        s(&sc),
        "--ratio",
        "1",
        "--gap-mm",
        "0.1",
        "--param",
        "ratio",
        "--values",
        "0.9:1.1:0.1",
        "--out",
        s(&out),
    ]);
    assert_fails_with(
        &o,
        &[
            "does not run a [two_plane] scenario",
            "run, sweep, ensemble, map, poincare, placement, lyapunov, orbit, continue",
        ],
    );
    assert!(!out.exists());
    let cut = d.path().join("cut.toml");
    fs::write(
        &cut,
        format!("{TWO_PLANE}\n[cutting]\nspindle_rpm = 5000.0\n"),
    )
    .unwrap();
    let o = vibrobar(&["sweep", "--scenario", s(&cut), "--out", s(&out)]);
    assert_fails_with(&o, &["[cutting]"]);
}

#[test]
fn a_two_plane_run_writes_its_history_and_its_summary_agrees_with_it() {
    let d = tempfile::tempdir().unwrap();
    let sc = d.path().join("tp.toml");
    fs::write(&sc, TWO_PLANE.replace("gap_m = 1.0e-3", "gap_m = 1.0e-4")).unwrap();
    let out = d.path().join("h/run.csv");
    let o = vibrobar_ok(&[
        "run",
        "--scenario",
        s(&sc),
        "--out",
        s(&out),
        "--sample-every",
        "5",
        "--member",
        "2",
    ]);
    let say = String::from_utf8_lossy(&o.stdout).to_string();
    for w in [
        "two planes",
        "solver exact, member 2",
        "plugs",
        "hole wall",
        "residual",
    ] {
        assert!(say.contains(w), "summary lacks {w:?}: {say}");
    }
    let csv = fs::read_to_string(&out).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "t_s,u_x_m,u_y_m,du_x_m_s,du_y_m_s,u_force_m,w_along_m,w_across_m,dw_along_m_s,\
         dw_across_m_s,spin_rad_s"
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    // 0.5 s every 5 µs, both ends.
    assert_eq!(rows.len(), 100_001);
    // The ball stays in the hole: ±0.05 mm along, ±0.05 mm across.
    for r in &rows {
        assert!(r.iter().all(|v| v.is_finite()));
        assert!(
            r[6].abs() <= 0.05e-3 + 1e-12 && r[7].abs() <= 0.05e-3 + 1e-12,
            "{r:?}"
        );
    }
    // The RMS along the force of the samples in the window (the last 80 %) is the summary's.
    let window: Vec<f64> = rows.iter().filter(|r| r[0] >= 0.1).map(|r| r[5]).collect();
    let rms = (window.iter().map(|v| v * v).sum::<f64>() / window.len() as f64).sqrt();
    let said: f64 = say
        .split("along the force ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .unwrap()
        .parse()
        .unwrap();
    assert!(
        (rms - said).abs() < 2e-3 * said,
        "samples {rms} against {said}"
    );
    // Its parameters beside it; a member outside the ensemble, the one-plane start flags and a
    // binary history are refused, and nothing is written.
    assert!(d.path().join("h/run.csv.meta.json").exists());
    let other = d.path().join("other.csv");
    for (flags, words) in [
        (&["--member", "8"][..], &["--member = 8", "[0, 7]"][..]),
        (&["--w0-m", "0"][..], &["--w0-m", "--member"][..]),
    ] {
        let mut args = vec!["run", "--scenario", s(&sc), "--out", s(&other)];
        args.extend_from_slice(flags);
        assert_fails_with(&vibrobar(&args), words);
        assert!(!other.exists());
    }
    let npy = d.path().join("run.npy");
    assert_fails_with(
        &vibrobar(&["run", "--scenario", s(&sc), "--out", s(&npy)]),
        &["--out", ".csv"],
    );
    assert!(!npy.exists());
    let plain = d.path().join("plain.csv");
    assert_fails_with(
        &vibrobar(&[
            "run",
            "--member",
            "1",
            "--duration",
            "0.01",
            "--out",
            s(&plain),
        ]),
        &["--member", "[two_plane]"],
    );
    assert!(!plain.exists());
}

#[test]
fn a_two_plane_ensemble_writes_every_member_and_agrees_with_the_sweep() {
    let d = tempfile::tempdir().unwrap();
    let sc = d.path().join("tp.toml");
    fs::write(&sc, TWO_PLANE).unwrap();
    let out = d.path().join("ens.csv");
    let o = vibrobar_ok(&[
        "ensemble",
        "--scenario",
        s(&sc),
        "--ratios",
        "0.98:1.0:0.02",
        "--gap-mm",
        "1.0",
        "--members",
        "5",
        "--out",
        s(&out),
    ]);
    let said = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(
        said.contains("r = 0.98") && said.contains("r = 1:"),
        "{said}"
    );
    let csv = fs::read_to_string(&out).unwrap();
    let rows = sweep_rows(&csv);
    assert_eq!(rows.len(), 2 * 5);
    for (i, r) in rows.iter().enumerate() {
        assert_eq!(r["member"], (i % 5).to_string());
        assert_eq!(r["solver"], "exact");
        let rms: f64 = r["rms_along_force_m"].parse().unwrap();
        let solid: f64 = r["solid_rms_m"].parse().unwrap();
        let red: f64 = r["reduction_pct"].parse().unwrap();
        assert!((red - 100.0 * (1.0 - rms / solid)).abs() < 1e-3, "{r:?}");
        // Member 0 rests on the hole's wall, at rest.
        if r["member"] == "0" {
            assert_eq!(r["dw_along_start_m_s"].parse::<f64>().unwrap(), 0.0);
        }
    }
    // The same members as the sweep's: its mean is the mean of these rows.
    let sweep = d.path().join("sweep.csv");
    vibrobar_ok(&[
        "sweep",
        "--scenario",
        s(&sc),
        "--ratios",
        "0.98:1.0:0.02",
        "--gap-mm",
        "1.0",
        "--out",
        s(&sweep),
    ]);
    // The sweep takes its members from the file (8); the ensemble was told 5: compare the first
    // point's mean over the file's members instead.
    let ens8 = d.path().join("ens8.csv");
    vibrobar_ok(&[
        "ensemble",
        "--scenario",
        s(&sc),
        "--ratios",
        "0.98:1.0:0.02",
        "--gap-mm",
        "1.0",
        "--out",
        s(&ens8),
    ]);
    let e8 = sweep_rows(&fs::read_to_string(&ens8).unwrap());
    let sw = sweep_rows(&fs::read_to_string(&sweep).unwrap());
    for (p, srow) in sw.iter().enumerate() {
        let members: Vec<f64> = e8[8 * p..8 * (p + 1)]
            .iter()
            .map(|r| r["rms_along_force_m"].parse().unwrap())
            .collect();
        let mean = members.iter().sum::<f64>() / 8.0;
        let sweep_mean: f64 = srow["rms_along_force_mean_m"].parse().unwrap();
        assert!(
            (mean - sweep_mean).abs() <= 1e-12 * sweep_mean,
            "{mean} {sweep_mean}"
        );
    }
    // One-plane start ranges and sharding are refused by name, and nothing is written.
    let other = d.path().join("other.csv");
    for (flag, value) in [("--dw-m-s", "0.1"), ("--shard", "1/2")] {
        let o = vibrobar(&[
            "ensemble",
            "--scenario",
            s(&sc),
            "--ratio",
            "1",
            "--gap-mm",
            "1",
            flag,
            value,
            "--out",
            s(&other),
        ]);
        assert_fails_with(&o, &[flag]);
        assert!(!other.exists());
    }
}

#[test]
fn a_two_plane_map_over_hole_angles_and_diameters_is_the_ensembles_of_its_cells() {
    let d = tempfile::tempdir().unwrap();
    let sc = d.path().join("tp.toml");
    fs::write(
        &sc,
        TWO_PLANE.replace("duration_s = 0.5", "duration_s = 0.3"),
    )
    .unwrap();
    let out = d.path().join("map.csv");
    let o = vibrobar_ok(&[
        "map",
        "--scenario",
        s(&sc),
        "--ratios",
        "1:1:1",
        "--gaps-mm",
        "0.1:1.0:0.9",
        "--hole-angles-deg",
        "0:60:30",
        "--out",
        s(&out),
    ]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("best cell: hole at"));
    let rows = sweep_rows(&fs::read_to_string(&out).unwrap());
    assert_eq!(rows.len(), 2 * 3);
    // Gap × hole angle: the heat map beside the table.
    for f in ["map.reduction.png", "map.reduction.svg"] {
        assert!(d.path().join(f).exists(), "{f}");
    }
    let cell = |gap: &str, angle: &str| {
        rows.iter()
            .find(|r| r["axial_gap_m"] == gap && r["hole_angle_deg"] == angle)
            .unwrap_or_else(|| panic!("no cell {gap} {angle}"))
    };
    // A cell is the ensemble of its point: the scenario with that hole, the same members.
    let sc60 = d.path().join("tp60.toml");
    fs::write(
        &sc60,
        TWO_PLANE.replace("duration_s = 0.5", "duration_s = 0.3") + "hole_angle_deg = 60.0\n",
    )
    .unwrap();
    let ens = d.path().join("ens.csv");
    vibrobar_ok(&[
        "ensemble",
        "--scenario",
        s(&sc60),
        "--ratio",
        "1",
        "--gap-mm",
        "1.0",
        "--out",
        s(&ens),
    ]);
    let members = sweep_rows(&fs::read_to_string(&ens).unwrap());
    let mean = members
        .iter()
        .map(|r| r["reduction_pct"].parse::<f64>().unwrap())
        .sum::<f64>()
        / members.len() as f64;
    let c: f64 = cell("0.001", "60")["reduction_mean_pct"].parse().unwrap();
    assert!((mean - c).abs() < 1e-3, "{mean} against {c}");
    // Over hole diameters: the radial clearance column follows.
    let out2 = d.path().join("map2.csv");
    vibrobar_ok(&[
        "map",
        "--scenario",
        s(&sc),
        "--ratios",
        "1:1:1",
        "--gaps-mm",
        "1:1:1",
        "--hole-diameters-mm",
        "15.1:15.5:0.4",
        "--out",
        s(&out2),
    ]);
    let rows2 = sweep_rows(&fs::read_to_string(&out2).unwrap());
    // One gap: no map to draw.
    assert!(!d.path().join("map2.reduction.png").exists());
    let c_r: Vec<f64> = rows2
        .iter()
        .map(|r| r["radial_clearance_m"].parse().unwrap())
        .collect();
    assert!(
        (c_r[0] - 0.05e-3).abs() < 1e-12 && (c_r[1] - 0.25e-3).abs() < 1e-12,
        "{c_r:?}"
    );
    // Bad axes name their flag; nothing is written.
    let bad = d.path().join("bad.csv");
    for (flags, words) in [
        (
            &["--hole-diameters-mm", "14:15:1"][..],
            &["--hole-diameters-mm"][..],
        ),
        (
            &["--freqs-hz", "100:200:100"][..],
            &["--freqs-hz", "--ratios"][..],
        ),
        (&["--shard", "1/2"][..], &["--shard"][..]),
    ] {
        let mut args = vec![
            "map",
            "--scenario",
            s(&sc),
            "--gaps-mm",
            "1:1:1",
            "--out",
            s(&bad),
        ];
        if flags[0] != "--freqs-hz" {
            args.extend_from_slice(&["--ratios", "1:1:1"]);
        }
        args.extend_from_slice(flags);
        assert_fails_with(&vibrobar(&args), words);
        assert!(!bad.exists());
    }
    // The one-plane map has no hole.
    let o = vibrobar(&[
        "map",
        "--ratios",
        "1:1:1",
        "--gaps-mm",
        "1:1:1",
        "--hole-angles-deg",
        "0:10:10",
        "--friction",
        "none",
        "--out",
        s(&bad),
    ]);
    assert_fails_with(&o, &["--hole-angles-deg", "[two_plane]"]);
    assert!(!bad.exists());
}

#[test]
fn a_two_plane_poincare_section_samples_once_per_period_at_the_phase() {
    let d = tempfile::tempdir().unwrap();
    let sc = d.path().join("tp.toml");
    fs::write(&sc, TWO_PLANE).unwrap();
    let out = d.path().join("pc.csv");
    vibrobar_ok(&[
        "poincare",
        "--scenario",
        s(&sc),
        "--ratio",
        "1",
        "--gap-mm",
        "1",
        "--phase-deg",
        "90",
        "--transient",
        "0.2",
        "--member",
        "1",
        "--out",
        s(&out),
    ]);
    let rows = sweep_rows(&fs::read_to_string(&out).unwrap());
    let t: Vec<f64> = rows.iter().map(|r| r["t_s"].parse().unwrap()).collect();
    // The paper's bar at r = 1: Ω = √(K/M).
    let om = (9.22e6f64 / 0.644).sqrt();
    let period = 2.0 * std::f64::consts::PI / om;
    assert!(t[0] >= 0.2 && t[0] < 0.2 + period, "{}", t[0]);
    assert_eq!(t.len(), ((0.5 - t[0]) / period).floor() as usize + 1);
    for (j, tj) in t.iter().enumerate() {
        assert!((tj - (t[0] + j as f64 * period)).abs() < 1e-12);
        let phase = (om * tj).rem_euclid(2.0 * std::f64::consts::PI);
        assert!(
            (phase - std::f64::consts::FRAC_PI_2).abs() < 1e-9,
            "{phase}"
        );
    }
    for r in &rows {
        let w: f64 = r["w_along_m"].parse().unwrap();
        assert!(w.abs() <= 0.5e-3 + 1e-12);
    }
    for f in ["pc.npy", "pc.png", "pc.svg", "pc.csv.meta.json"] {
        assert!(d.path().join(f).exists(), "{f}");
    }
    // The one-plane section has no members.
    let bad = d.path().join("bad.csv");
    let o = vibrobar(&[
        "poincare",
        "--ratio",
        "1",
        "--gap-mm",
        "1",
        "--friction",
        "none",
        "--member",
        "1",
        "--out",
        s(&bad),
    ]);
    assert_fails_with(&o, &["--member", "[two_plane]"]);
    assert!(!bad.exists());
}

#[test]
fn a_two_plane_placement_on_a_beam_summarises_the_ensembles_of_its_band() {
    let d = tempfile::tempdir().unwrap();
    let text = "[damper]\ngap_m = 1.0e-4\n\n[run]\nduration_s = 0.2\n\n[beam]\nmodes = 2\n\
                cavity_position_m = 0.15\n\n[two_plane]\nhole_diameter_m = 0.0151\n\
                force_ratio = 2.0\nmembers = 3\n";
    let sc = d.path().join("beam.toml");
    fs::write(&sc, text).unwrap();
    let out = d.path().join("pl.csv");
    let o = vibrobar_ok(&[
        "placement",
        "--scenario",
        s(&sc),
        "--positions-mm",
        "125:175:25",
        "--gaps-mm",
        "0.1:0.1:1",
        "--ratios",
        "1:1:1",
        "--out",
        s(&out),
    ]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("best: the cavity at"));
    let rows = sweep_rows(&fs::read_to_string(&out).unwrap());
    assert_eq!(rows.len(), 3);
    // The row at the scenario's own position is the ensemble there (one ratio: its mean).
    let ens = d.path().join("ens.csv");
    vibrobar_ok(&[
        "ensemble",
        "--scenario",
        s(&sc),
        "--ratio",
        "1",
        "--gap-mm",
        "0.1",
        "--out",
        s(&ens),
    ]);
    let members = sweep_rows(&fs::read_to_string(&ens).unwrap());
    let mean = members
        .iter()
        .map(|r| r["reduction_pct"].parse::<f64>().unwrap())
        .sum::<f64>()
        / members.len() as f64;
    let row = rows.iter().find(|r| r["position_mm"] == "150").unwrap();
    let got: f64 = row["mean_reduction_pct"].parse().unwrap();
    assert!((got - mean).abs() < 1e-3, "{got} against {mean}");
    assert_eq!(row["solver"], "exact");
    // Positions outside the bar and sharding are refused by name; nothing is written.
    let bad = d.path().join("bad.csv");
    for (flag, value, word) in [
        ("--positions-mm", "150:200:50", "--positions-mm"),
        ("--shard", "1/2", "--shard"),
    ] {
        let mut args = vec![
            "placement",
            "--scenario",
            s(&sc),
            "--gaps-mm",
            "0.1:0.1:1",
            "--ratios",
            "1:1:1",
            "--out",
            s(&bad),
        ];
        if flag == "--shard" {
            args.extend_from_slice(&["--positions-mm", "150:150:1"]);
        }
        args.extend_from_slice(&[flag, value]);
        assert_fails_with(&vibrobar(&args), &[word]);
        assert!(!bad.exists());
    }
}

#[test]
fn a_two_plane_lyapunov_exponent_is_positive_where_the_ball_is_chaotic_across_the_hole() {
    let d = tempfile::tempdir().unwrap();
    let sc = d.path().join("tp.toml");
    fs::write(
        &sc,
        TWO_PLANE.replace("duration_s = 0.5", "duration_s = 1.0"),
    )
    .unwrap();
    let o = vibrobar_ok(&[
        "lyapunov",
        "--scenario",
        s(&sc),
        "--ratio",
        "1",
        "--gap-mm",
        "1",
        "--json",
    ]);
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let (l, se) = (
        j["exponent_per_s"].as_f64().unwrap(),
        j["std_error_per_s"].as_f64().unwrap(),
    );
    assert!(l > 5.0 * se, "{j}");
    assert_eq!(j["solver"], "exact");
    assert_eq!(j["member"], 0);
    // With friction on the walls the spectrum needs saltation matrices that are not derived:
    // refused, saying so.
    let rough = d.path().join("rough.toml");
    fs::write(
        &rough,
        format!("{TWO_PLANE}friction_static = 0.3\nfriction_kinetic = 0.2\n"),
    )
    .unwrap();
    let o = vibrobar(&[
        "lyapunov",
        "--scenario",
        s(&rough),
        "--ratio",
        "1",
        "--gap-mm",
        "1",
        "--spectrum",
    ]);
    assert_fails_with(&o, &["decouple", "saltation", "frictionless walls"]);
}

/// A tight hole (0.04 mm axial gap, 0.04 mm radial clearance) at r = 1, the force at 63.4°:
/// a stable two-impact orbit in each plane.
const TIGHT: &str = "[damper]\ngap_m = 0.04e-3\n\n[run]\nduration_s = 0.3\n\n[two_plane]\n\
hole_diameter_m = 0.01508\nforce_ratio = 2.0\nmembers = 4\n";

#[test]
fn a_two_plane_orbit_and_spectrum_agree_and_refuse_what_they_cannot_do() {
    let d = tempfile::tempdir().unwrap();
    let sc = d.path().join("tight.toml");
    fs::write(&sc, TIGHT).unwrap();
    let out = d.path().join("o.json");
    let point = ["--scenario", s(&sc), "--ratio", "1", "--gap-mm", "0.04"];
    let mut args = vec!["orbit"];
    args.extend_from_slice(&point);
    args.extend_from_slice(&["--out", s(&out)]);
    vibrobar_ok(&args);
    let j: serde_json::Value = serde_json::from_str(&fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(j["stable"], true, "{j}");
    assert_eq!(j["multipliers"].as_array().unwrap().len(), 8);
    assert!(
        j["return_gap"].as_f64().unwrap() < 1e-9,
        "{}",
        j["return_gap"]
    );
    for plane in ["along_hole", "across_hole"] {
        assert_eq!(j["planes"][plane]["impacts_per_period"], 2, "{plane}");
    }
    let walls = &j["impacts_per_wall"];
    for w in ["plug_plus", "plug_minus", "wall_plus", "wall_minus"] {
        assert_eq!(walls[w], 1, "{w}");
    }
    let red = j["reduction_pct"].as_f64().unwrap();
    assert!(red > 50.0 && red < 100.0, "{red}");
    assert!(d.path().join("o.json.meta.json").exists());
    // The spectrum along the run: its largest exponent is ln max|λ| / T of the orbit.
    let mut args = vec!["lyapunov"];
    args.extend_from_slice(&point);
    args.extend_from_slice(&["--spectrum", "--json", "--duration", "1.0"]);
    let o = vibrobar_ok(&args);
    let sp: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let top = ["along_hole", "across_hole"]
        .iter()
        .flat_map(|p| sp[*p]["exponents_per_s"].as_array().unwrap().clone())
        .filter_map(|x| x.as_f64())
        .fold(f64::NEG_INFINITY, f64::max);
    let period_s = 2.0 * std::f64::consts::PI / (9.22e6f64 / 0.644).sqrt();
    let expected = j["max_abs_multiplier"].as_f64().unwrap().ln() / period_s;
    assert!(
        (top - expected).abs() < 0.03 * expected.abs(),
        "largest exponent {top} against the orbit's {expected}"
    );
    assert_eq!(sp["spin_exponent_per_s"], 0.0);
    // What does not apply is refused by name, and nothing is written.
    fs::remove_file(&out).unwrap();
    fs::remove_file(d.path().join("o.json.meta.json")).unwrap();
    for (extra, words) in [
        (
            &["--start", "symmetric"][..],
            &["--start symmetric", "one-plane"][..],
        ),
        (&["--member", "9"][..], &["--member = 9", "[0, 3]"][..]),
        (
            &["--solver", "rk4"][..],
            &["--solver", "[two_plane] solver"][..],
        ),
    ] {
        let mut args = vec!["orbit"];
        args.extend_from_slice(&point);
        args.extend_from_slice(extra);
        args.extend_from_slice(&["--out", s(&out)]);
        assert_fails_with(&vibrobar(&args), words);
        assert!(!out.exists(), "{extra:?}");
    }
    let rough = d.path().join("rough.toml");
    fs::write(&rough, format!("{TIGHT}friction_static = 0.3\n")).unwrap();
    let o = vibrobar(&[
        "orbit",
        "--scenario",
        s(&rough),
        "--ratio",
        "1",
        "--gap-mm",
        "0.04",
        "--out",
        s(&out),
    ]);
    assert_fails_with(&o, &["decouple", "frictionless walls"]);
    assert!(!out.exists());
    // The one-plane orbit has no ensemble to pick a member from.
    let o = vibrobar(&[
        "orbit",
        "--friction",
        "none",
        "--ratio",
        "1",
        "--gap-mm",
        "0.08",
        "--member",
        "1",
        "--out",
        s(&out),
    ]);
    assert_fails_with(&o, &["--member", "[two_plane]"]);
}

#[test]
fn a_two_plane_continuation_follows_each_plane_from_the_orbit() {
    let d = tempfile::tempdir().unwrap();
    let sc = d.path().join("tight.toml");
    fs::write(&sc, TIGHT).unwrap();
    let orbit = d.path().join("o.json");
    vibrobar_ok(&[
        "orbit",
        "--scenario",
        s(&sc),
        "--ratio",
        "1",
        "--gap-mm",
        "0.04",
        "--out",
        s(&orbit),
    ]);
    let j: serde_json::Value = serde_json::from_str(&fs::read_to_string(&orbit).unwrap()).unwrap();
    let out = d.path().join("c.csv");
    let o = vibrobar_ok(&[
        "continue",
        "--scenario",
        s(&sc),
        "--param",
        "ratio",
        "--from",
        "1",
        "--to",
        "1.05",
        "--gap-mm",
        "0.04",
        "--out",
        s(&out),
    ]);
    let text = fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "plane,param,rms_m,max_abs_multiplier,stable,impacts_per_period,period,event"
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    for plane in ["along_hole", "across_hole"] {
        let mine: Vec<&Vec<&str>> = rows.iter().filter(|r| r[0] == plane).collect();
        assert!(mine.len() > 20, "{plane}: {} rows", mine.len());
        // The branch starts at the orbit of `orbit`, in the scenario's ratio.
        let first = mine[0];
        assert_eq!(first[1], "1", "{plane}");
        let m: f64 = first[3].parse().unwrap();
        let m_orbit = j["planes"][plane]["max_abs_multiplier"].as_f64().unwrap();
        assert!((m - m_orbit).abs() < 1e-6, "{plane}: {m} against {m_orbit}");
        assert_eq!(first[4], "true");
        // It reaches the end of the interval, through a torus bifurcation of the two-impact
        // orbit near 1.027.
        let last: f64 = mine.last().unwrap()[1].parse().unwrap();
        assert!((last - 1.05).abs() < 1e-9, "{plane}: ends at {last}");
        let torus: Vec<f64> = mine
            .iter()
            .filter(|r| r[7] == "torus")
            .map(|r| r[1].parse().unwrap())
            .collect();
        assert!(
            torus.iter().any(|t| (t - 1.027).abs() < 0.002),
            "{plane}: {torus:?}"
        );
    }
    assert!(String::from_utf8_lossy(&o.stdout).contains("stable where both are"));
    for f in ["c.along_hole.png", "c.across_hole.svg", "c.csv.meta.json"] {
        assert!(d.path().join(f).exists(), "{f}");
    }
    // The axial gap acts on the plane along the hole only.
    let gap = d.path().join("g.csv");
    let o = vibrobar_ok(&[
        "continue",
        "--scenario",
        s(&sc),
        "--param",
        "gap-mm",
        "--from",
        "0.04",
        "--to",
        "0.05",
        "--ratio",
        "1",
        "--out",
        s(&gap),
    ]);
    let text = fs::read_to_string(&gap).unwrap();
    assert!(text.lines().skip(1).all(|l| l.starts_with("along_hole,")));
    assert!(String::from_utf8_lossy(&o.stdout).contains("across the hole: gap-mm does not act"));
    // Refused by name, nothing written.
    let bad = d.path().join("bad.csv");
    for (extra, words) in [
        (
            &["--param", "ratio", "--from", "0.97", "--to", "1.0"][..],
            &["floats along the hole", "continuum"][..],
        ),
        (
            &[
                "--param",
                "friction-force-n",
                "--from",
                "1",
                "--to",
                "2",
                "--ratio",
                "1",
            ][..],
            &["--param friction-force-n", "couples the planes"][..],
        ),
        (
            &[
                "--param", "ratio", "--from", "1", "--to", "1.05", "--member", "7",
            ][..],
            &["--member = 7"][..],
        ),
    ] {
        let mut args = vec!["continue", "--scenario", s(&sc), "--gap-mm", "0.04"];
        args.extend_from_slice(extra);
        args.extend_from_slice(&["--out", s(&bad)]);
        assert_fails_with(&vibrobar(&args), words);
        assert!(!bad.exists());
    }
}

/// Measured modes with the direction each bends in: two perpendicular families.
fn measured(dirs: [&str; 4]) -> String {
    let mut t = String::from(
        "[damper]\ngap_m = 1.0e-4\n\n[run]\nduration_s = 0.05\n\n[two_plane]\n\
         hole_angle_deg = 20.0\nhole_diameter_m = 0.0151\nforce_ratio = 2.0\nmembers = 2\n",
    );
    for (i, (f, d)) in [600.0, 612.0, 3700.0, 3770.0].iter().zip(dirs).enumerate() {
        t += &format!(
            "\n[[modes]]\nfrequency_hz = {f}\ndamping_ratio = 0.01\nmodal_mass_kg = 0.16\n\
             shape_cavity = {}\n{d}",
            if i < 2 { 0.7 } else { -0.4 }
        );
    }
    t
}

#[test]
fn measured_modes_with_directions_run_and_bad_directions_are_refused() {
    let d = tempfile::tempdir().unwrap();
    let sc = d.path().join("m.toml");
    let out = d.path().join("run.csv");
    // The families at 20° and 110°: along and across the hole at 20°, the exact solver runs.
    fs::write(
        &sc,
        measured([
            "direction_deg = 20.0\n",
            "direction_deg = 110.0\n",
            "direction_deg = 200.0\n",
            "direction_deg = -70.0\n",
        ]),
    )
    .unwrap();
    let o = vibrobar_ok(&["run", "--scenario", s(&sc), "--out", s(&out)]);
    assert!(
        String::from_utf8_lossy(&o.stdout).contains("solver exact"),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    assert!(out.exists());
    fs::remove_file(&out).unwrap();
    for (dirs, words) in [
        (
            ["direction_deg = 20.0\n", "", "", ""],
            &["direction_deg", "1 of 4 entries"][..],
        ),
        (
            [
                "direction_deg = 20.0\n",
                "direction_deg = 70.0\n",
                "direction_deg = 20.0\n",
                "direction_deg = 110.0\n",
            ],
            &["modes[1].direction_deg = 70", "perpendicular"][..],
        ),
        (
            [
                "direction_deg = 20.0\n",
                "direction_deg = 20.0\n",
                "direction_deg = 200.0\n",
                "direction_deg = 20.0\n",
            ],
            &["every mode bends along 20°"][..],
        ),
        (
            [
                "direction_deg = 50.0\n",
                "direction_deg = 140.0\n",
                "direction_deg = 50.0\n",
                "direction_deg = 140.0\n",
            ],
            &[
                "a bar of modes runs on the exact solver",
                "along and across the hole",
            ][..],
        ),
    ] {
        fs::write(&sc, measured(dirs)).unwrap();
        assert_fails_with(
            &vibrobar(&["run", "--scenario", s(&sc), "--out", s(&out)]),
            words,
        );
        assert!(!out.exists(), "{dirs:?}");
    }
    // One plane has no place for a direction.
    let one = measured(["direction_deg = 20.0\n", "", "", ""]);
    let one = &one[..one.find("[two_plane]").unwrap()];
    let rest = measured(["direction_deg = 20.0\n", "", "", ""]);
    let modes = &rest[rest.find("\n[[modes]]").unwrap()..];
    fs::write(&sc, format!("{one}{modes}")).unwrap();
    assert_fails_with(
        &vibrobar(&["run", "--scenario", s(&sc), "--out", s(&out)]),
        &["modes[0].direction_deg", "[two_plane]"],
    );
    assert!(!out.exists());
}

#[test]
fn one_plane_flags_on_a_two_plane_scenario_are_refused_by_name() {
    let d = tempfile::tempdir().unwrap();
    let sc = d.path().join("tp.toml");
    fs::write(&sc, TWO_PLANE).unwrap();
    let out = d.path().join("o.csv");
    let cases: [(&[&str], &[&str]); 6] = [
        (
            &["sweep", "--friction", "coulomb"],
            &["--friction", "friction_static"],
        ),
        (
            &["run", "--solver", "rk4"],
            &["--solver", "[two_plane] solver"],
        ),
        (
            &[
                "ensemble",
                "--ratio",
                "1",
                "--gap-mm",
                "1",
                "--contact",
                "hertz",
            ],
            &["--contact", "restitution"],
        ),
        (
            &[
                "map",
                "--ratios",
                "1:1:1",
                "--gaps-mm",
                "1:1:1",
                "--friction-force-n",
                "2",
            ],
            &["--friction-force-n"],
        ),
        (
            &[
                "poincare",
                "--ratio",
                "1",
                "--gap-mm",
                "1",
                "--friction",
                "coulomb",
            ],
            &["--friction"],
        ),
        (
            &[
                "lyapunov", "--ratio", "1", "--gap-mm", "1", "--solver", "exact",
            ],
            &["--solver"],
        ),
    ];
    for (args, words) in cases {
        let mut all = vec![args[0], "--scenario", s(&sc)];
        all.extend_from_slice(&args[1..]);
        if args[0] != "lyapunov" {
            all.extend_from_slice(&["--out", s(&out)]);
        }
        assert_fails_with(&vibrobar(&all), words);
        assert!(!out.exists(), "{args:?}");
    }
}
