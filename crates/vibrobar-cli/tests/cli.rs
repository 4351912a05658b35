//! End-to-end tests of the `vibrobar` binary: headers, ranges, validation, atomic writes,
//! a snapshot of a small sweep, closed-form plausibility and `paper --quick`.

mod common;

use common::{vibrobar, vibrobar_ok};
use std::path::Path;

fn csv(path: &Path) -> (String, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).expect("csv written");
    let mut lines = text.lines();
    let header = lines.next().expect("header").to_string();
    let rows = lines
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect();
    (header, rows)
}

fn no_partial_files(dir: &Path) {
    for e in std::fs::read_dir(dir).expect("dir") {
        let p = e.expect("entry").path();
        assert!(
            !p.to_string_lossy().contains(".partial"),
            "left behind: {}",
            p.display()
        );
        if p.is_dir() {
            no_partial_files(&p);
        }
    }
}

fn col(rows: &[Vec<String>], i: usize) -> Vec<f64> {
    rows.iter().map(|r| r[i].parse().expect("number")).collect()
}

#[test]
fn sweep_header_and_inclusive_range() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("nested/dir/sweep.csv");
    let o = out.to_str().unwrap();
    vibrobar_ok(&[
        "sweep",
        "--preset",
        "paper",
        "--friction",
        "none",
        "--gap-mm",
        "0.1",
        "--ratios",
        "0.95:1.05:0.01",
        "--dt",
        "1e-5",
        "--duration",
        "0.01",
        "--out",
        o,
    ]);
    let (header, rows) = csv(&out);
    assert_eq!(
        header,
        "ratio,gap_mm,friction,solver,rms_solid_m,rms_damped_m,reduction_pct,impacts"
    );
    assert_eq!(rows.len(), 11);
    let ratios = col(&rows, 0);
    for (i, r) in ratios.iter().enumerate() {
        assert!(
            (r - (0.95 + i as f64 * 0.01)).abs() < 1e-9,
            "ratio {i} = {r}"
        );
    }
    assert!(rows
        .iter()
        .all(|r| r[2] == "none" && r[3] == vibrobar_cli::DEFAULT_SOLVER));
    no_partial_files(dir.path());
}

#[test]
fn sweep_two_gaps_and_friction_options() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("s.csv");
    vibrobar_ok(&[
        "sweep",
        "--preset",
        "paper",
        "--friction",
        "as-published",
        "--friction-force-n",
        "20",
        "--gap-mm",
        "0.1,1.0",
        "--ratios",
        "0.99:1.01:0.01",
        "--dt",
        "1e-5",
        "--duration",
        "0.02",
        "--solver",
        "rk4",
        "--out",
        out.to_str().unwrap(),
    ]);
    let (_, rows) = csv(&out);
    assert_eq!(rows.len(), 6);
    assert_eq!(col(&rows, 1), vec![0.1, 0.1, 0.1, 1.0, 1.0, 1.0]);
    assert!(rows.iter().all(|r| r[2] == "as-published"));
}

#[test]
fn run_header_rows_and_summary() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run.csv");
    let o = vibrobar_ok(&[
        "run",
        "--preset",
        "paper",
        "--friction",
        "coulomb",
        "--gap-mm",
        "1",
        "--ratio",
        "1",
        "--dt",
        "1e-6",
        "--duration",
        "0.01",
        "--sample-every",
        "100",
        "--w0-m",
        "1e-4",
        "--dw0-m-s",
        "0.01",
        "--u0-m",
        "1e-6",
        "--out",
        out.to_str().unwrap(),
    ]);
    let (header, rows) = csv(&out);
    assert_eq!(header, "t_s,u_m,du_m_s,v_m,dv_m_s,w_m,dw_m_s");
    // 0.01 s sampled every 100·1e-6 s, both ends included.
    assert_eq!(rows.len(), 101);
    let t = col(&rows, 0);
    assert!((t[1] - 1e-4).abs() < 1e-12 && (t[100] - 0.01).abs() < 1e-9);
    // Initial conditions are honoured: w = v − u and the given values at t = 0.
    let r0: Vec<f64> = rows[0].iter().map(|x| x.parse().unwrap()).collect();
    assert!((r0[1] - 1e-6).abs() < 1e-15);
    assert!((r0[5] - 1e-4).abs() < 1e-15);
    assert!((r0[6] - 0.01).abs() < 1e-12);
    assert!((r0[3] - r0[1] - r0[5]).abs() < 1e-15);
    let stdout = String::from_utf8_lossy(&o.stdout);
    for key in [
        "RMS",
        "impacts",
        "per forcing cycle",
        "penetration",
        vibrobar_cli::DEFAULT_SOLVER,
        "wall time",
    ] {
        assert!(stdout.contains(key), "summary lacks {key:?}:\n{stdout}");
    }
    no_partial_files(dir.path());
}

#[test]
fn invalid_input_names_the_field_and_fails_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let bad = |name: &str, body: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, body).unwrap();
        p.to_str().unwrap().to_string()
    };
    let mass = bad(
        "mass.toml",
        "[bar]\nmass_kg = 0\nstiffness_n_per_m = 9.22e6\ndamping_ratio = 0.01\n",
    );
    let stiff = bad(
        "stiff.toml",
        "[bar]\nmass_kg = 0.644\nstiffness_n_per_m = -1\ndamping_ratio = 0.01\n",
    );
    let e = bad("e.toml", "[damper]\nrestitution = 1.5\n");
    let typo = bad("typo.toml", "[damper]\nrestitutio = 0.5\n");
    let gap = bad("gap.toml", "[damper]\ngap_m = 0.0\n");
    let sweep_gap = bad("sgap.toml", "[sweep]\ngaps_m = [1e-4, -1e-3]\n");
    let nan = bad("nan.toml", "[forcing]\namplitude_n = nan\n");
    let out = dir.path().join("x.csv");
    let out = out.to_str().unwrap();
    let r = ["--ratios", "1:1:0.01"];
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["sweep", "--scenario", &mass], "bar.mass_kg"),
        (vec!["sweep", "--scenario", &stiff], "bar.stiffness_n_per_m"),
        (vec!["sweep", "--scenario", &e], "damper.restitution"),
        (vec!["sweep", "--scenario", &typo], "restitutio"),
        (vec!["run", "--scenario", &gap], "damper.gap_m"),
        (vec!["sweep", "--scenario", &sweep_gap], "damper.gap_m"),
        (vec!["sweep", "--scenario", &nan], "forcing.amplitude_n"),
        (vec!["sweep", "--gap-mm", "0"], "--gap-mm"),
        (vec!["sweep", "--gap-mm", "-0.1"], "--gap-mm"),
        (vec!["sweep", "--gap-mm", "nan"], "--gap-mm"),
        (vec!["sweep", "--dt", "0"], "--dt"),
        (vec!["sweep", "--dt", "inf"], "--dt"),
        (vec!["sweep", "--duration", "-2"], "--duration"),
        (
            vec!["sweep", "--friction-force-n", "-1"],
            "--friction-force-n",
        ),
        (vec!["sweep", "--solver", "nope"], "solver"),
        (vec!["run", "--gap-mm", "0.1", "--w0-m", "1"], "initial.w_m"),
        (vec!["run", "--ratio", "0"], "--ratio"),
        (vec!["run", "--ratio", "nan"], "--ratio"),
        (vec!["run", "--sample-every", "0"], "--sample-every"),
        (vec!["paper", "--duration", "0", "--out", out], "--duration"),
    ];
    let range_cases: Vec<(&str, &str)> = vec![
        ("1.05:0.95:0.01", "STOP"),
        ("0.95:1.05:0", "STEP"),
        ("0.95:1.05:-0.01", "STEP"),
        ("0.95:1.05", "START:STOP:STEP"),
        ("a:1.05:0.01", "START"),
        ("0.95:1.05:nan", "STEP"),
        ("0:1.05:0.01", "START"),
    ];
    let mut all: Vec<(Vec<String>, String)> = cases
        .into_iter()
        .map(|(mut a, f)| {
            if a[0] == "sweep" && !a.contains(&"--ratios") {
                a.extend(r);
            }
            if !a.contains(&"--out") {
                a.extend(["--out", out]);
            }
            (a.iter().map(|s| s.to_string()).collect(), f.to_string())
        })
        .collect();
    for (spec, f) in range_cases {
        all.push((
            ["sweep", "--ratios", spec, "--out", out]
                .iter()
                .map(|s| s.to_string())
                .collect(),
            f.to_string(),
        ));
    }
    for (args, field) in all {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = vibrobar(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?} should fail");
        assert!(
            err.contains(&field),
            "{args:?}: message lacks {field:?}: {err}"
        );
        assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
        assert!(!Path::new(out).exists(), "{args:?} wrote output");
    }
    no_partial_files(dir.path());
}

/// Snapshot of a short sweep (0.05 s, rk4, dt = 1 µs). Regenerate deliberately if the scheme
/// changes on purpose; an unexpected change is a regression.
#[test]
fn small_sweep_snapshot() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("snap.csv");
    vibrobar_ok(&[
        "sweep",
        "--preset",
        "paper",
        "--friction",
        "none",
        "--gap-mm",
        "0.1",
        "--ratios",
        "0.99:1.01:0.01",
        "--solver",
        "rk4",
        "--dt",
        "1e-6",
        "--duration",
        "0.05",
        "--out",
        out.to_str().unwrap(),
    ]);
    let (_, rows) = csv(&out);
    let expected = [
        (0.99, 3.532551683392727e-5, 2.7903488052312838e-5, 29),
        (1.00, 3.7872274446298044e-5, 2.601726970708355e-5, 32),
        (1.01, 3.511814120035336e-5, 2.4767393048070377e-5, 26),
    ];
    assert_eq!(rows.len(), expected.len());
    for (row, (r, solid, damped, impacts)) in rows.iter().zip(expected) {
        let v: Vec<f64> = [0, 4, 5].iter().map(|&i| row[i].parse().unwrap()).collect();
        assert!((v[0] - r).abs() < 1e-9);
        assert!(
            (v[1] / solid - 1.0).abs() < 1e-6,
            "solid {} vs {solid}",
            v[1]
        );
        assert!(
            (v[2] / damped - 1.0).abs() < 1e-3,
            "damped {} vs {damped}",
            v[2]
        );
        assert_eq!(row[7].parse::<u64>().unwrap(), impacts);
        let red: f64 = row[6].parse().unwrap();
        assert!((red - 100.0 * (1.0 - damped / solid)).abs() < 0.1);
    }
}

/// Solid-bar RMS against the closed-form steady amplitude X = F0/K / √((1−r²)² + (2ζr)²),
/// RMS = X/√2, after the transient (time constant 1/(ζωn) ≈ 27 ms) has died out.
#[test]
fn solid_bar_rms_matches_closed_form() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("solid.csv");
    vibrobar_ok(&[
        "sweep",
        "--preset",
        "paper",
        "--friction",
        "none",
        "--gap-mm",
        "1",
        "--ratios",
        "0.95:1.05:0.05",
        "--dt",
        "1e-5",
        "--duration",
        "0.6",
        "--out",
        out.to_str().unwrap(),
    ]);
    let (_, rows) = csv(&out);
    assert_eq!(rows.len(), 3);
    let (f0, k, zeta) = (15.0, 9.26e6, 0.01);
    for row in &rows {
        let r: f64 = row[0].parse().unwrap();
        let rms: f64 = row[4].parse().unwrap();
        let x = f0 / k / ((1.0 - r * r).powi(2) + (2.0 * zeta * r).powi(2)).sqrt();
        let want = x / 2f64.sqrt();
        assert!(
            (rms / want - 1.0).abs() < 0.01,
            "r = {r}: RMS {rms} vs closed form {want}"
        );
    }
}

#[test]
fn paper_quick_writes_everything() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("paper-out");
    let o = vibrobar_ok(&[
        "paper",
        "--quick",
        "--duration",
        "0.02",
        "--out",
        out.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("REPORT.md") && stdout.contains("wall time"));
    let stems = [
        "fig2_frictionless_gap0.1mm_r1",
        "fig4_as-published_stated_gap1mm_r1",
        "fig4_as-published_20N_gap1mm_r1",
        "fig4_coulomb_stated_gap1mm_r1",
        "fig3_rms_frictionless",
        "fig5_rms_as-published_stated",
        "fig5_rms_as-published_20N",
        "fig5_rms_coulomb_stated",
    ];
    for s in stems {
        for ext in ["png", "svg", "csv"] {
            let p = out.join(format!("{s}.{ext}"));
            let len = std::fs::metadata(&p)
                .unwrap_or_else(|_| panic!("missing {}", p.display()))
                .len();
            assert!(len > 100, "{} is nearly empty", p.display());
        }
        let (header, rows) = csv(&out.join(format!("{s}.csv")));
        if s.contains("_rms_") {
            assert_eq!(
                header,
                "ratio,gap_mm,friction,solver,rms_solid_m,rms_damped_m,reduction_pct,impacts"
            );
            // Default `paper` reports rk4 (the paper's scheme) and exact side by side.
            let gaps = if s.starts_with("fig3") { 4 } else { 2 };
            assert_eq!(rows.len(), 2 * 11 * gaps, "{s}");
            for solver in ["rk4", "exact"] {
                assert_eq!(
                    rows.iter().filter(|r| r[3] == solver).count(),
                    11 * gaps,
                    "{s}: rows of {solver}"
                );
            }
        } else {
            assert_eq!(header, "t_s,u_m,du_m_s,v_m,dv_m_s,w_m,dw_m_s");
            assert!(rows.len() > 100);
        }
    }
    let report = std::fs::read_to_string(out.join("REPORT.md")).unwrap();
    for id in [
        "F1", "F2", "F3", "F4", "R1", "R2", "R3", "R4", "R5", "R6", "R7", "R8", "R9", "F5", "F6",
        "R10",
    ] {
        let n = report.matches(&format!("| {id} |")).count();
        // Summary row plus one row per parameter set.
        assert!(n >= 2, "claim {id} appears {n} times in REPORT.md");
    }
    for needle in [
        "83 %",
        "56 %",
        "rk4: verdict",
        "injects energy",
        "NOT the paper's run settings",
        "as published, F = 20 N",
        "physically consistent",
        "Energy books",
        "the work of the cutting force",
        "Robustness to initial conditions",
        "exact ensemble: verdict",
        "seed 1",
    ] {
        assert!(report.contains(needle), "REPORT.md lacks {needle:?}");
    }
    // Claim C1 (issue #9): restitution against hertz on the same cases, with its verdict.
    let c1 = report
        .lines()
        .find(|l| l.starts_with("| C1 |"))
        .expect("claim C1 in REPORT.md");
    assert!(c1.contains("adequate model") && c1.contains("s.e."), "{c1}");
    assert!(report.contains("exact: restitution vs hertz"));
    // Initial-condition ensemble: --quick has 4 members; frictionless 0.1 mm at the 11 ratios,
    // then the three friction sets at 1 mm, r = 1.
    let (header, rows) = csv(&out.join("ic_ensemble.csv"));
    assert!(header.starts_with("set,friction,friction_force_n,gap_mm,ratio,solver,seed,members,"));
    assert!(header.contains("impacting_members,impacting_fraction,regimes"));
    assert_eq!(rows.len(), 11 + 3);
    let col = |name: &str| header.split(',').position(|h| h == name).unwrap();
    for r in &rows {
        assert_eq!(r[col("solver")], "exact");
        assert_eq!(r[col("members")], "4");
        let k: usize = r[col("impacting_members")].parse().unwrap();
        assert!(k <= 4);
        let mean: f64 = r[col("mean_rms_m")].parse().unwrap();
        assert!(mean > 0.0 && mean.is_finite());
    }
    assert_eq!(rows.iter().filter(|r| r[0] == "frictionless").count(), 11);
    assert_eq!(rows[11][col("ratio")], "1");
    assert_eq!(rows[11][col("gap_mm")], "1");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    // 16 claims of the paper, C1 (instantaneous impacts against hertz) and T1, T2 (the gaps on
    // the bar that bends in two planes).
    assert_eq!(json["claims"].as_array().unwrap().len(), 19);
    let two = json["two_plane"].as_array().unwrap();
    assert_eq!(two.len(), 8);
    for p in two {
        assert_eq!(p["solver"], "exact");
        assert!(p["two_plane_pct"][0].as_f64().unwrap().is_finite());
    }
    assert!(json["contact_laws"]["mean_abs_pp"]
        .as_f64()
        .unwrap()
        .is_finite());
    assert_eq!(json["ic_ensemble"]["points"].as_array().unwrap().len(), 14);
    assert_eq!(json["ic_ensemble"]["seed"], 1);
    no_partial_files(&out);

    // --ensemble-members 0 skips the ensemble: no CSV, no claims from it.
    let out0 = dir.path().join("paper-no-ensemble");
    vibrobar_ok(&[
        "paper",
        "--quick",
        "--duration",
        "0.02",
        "--solvers",
        "exact",
        "--ensemble-members",
        "0",
        "--out",
        out0.to_str().unwrap(),
    ]);
    assert!(!out0.join("ic_ensemble.csv").exists());
    let report = std::fs::read_to_string(out0.join("REPORT.md")).unwrap();
    assert!(!report.contains("| F5 |") && !report.contains("Robustness to initial"));
    no_partial_files(&out0);
}

#[test]
fn shipped_scenario_parses_and_runs() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run.csv");
    let scenario = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios/paper.toml");
    vibrobar_ok(&[
        "run",
        "--scenario",
        scenario,
        "--duration",
        "0.001",
        "--out",
        out.to_str().unwrap(),
    ]);
    let text = std::fs::read_to_string(scenario).unwrap();
    let sc = vibrobar_cli::scenario::Scenario::from_toml(&text).unwrap();
    assert_eq!(sc, vibrobar_cli::scenario::Scenario::paper());
}

#[test]
fn help_is_complete() {
    for cmd in ["sweep", "run", "paper", "bench"] {
        let o = vibrobar_ok(&[cmd, "--help"]);
        let h = String::from_utf8_lossy(&o.stdout);
        assert!(h.contains("--"), "{cmd} help empty");
    }
    let h = String::from_utf8_lossy(&vibrobar_ok(&["sweep", "--help"]).stdout).to_string();
    for flag in [
        "--gap-mm",
        "--ratios",
        "--friction-force-n",
        "--dt",
        "--duration",
        "--out",
    ] {
        assert!(h.contains(flag), "sweep help lacks {flag}");
    }
    assert!(h.contains(" mm") && h.contains(" s") && h.contains(" N"));
}

#[test]
fn ratio_ranges_include_stop() {
    use vibrobar_cli::scenario::parse_ratios;
    assert_eq!(parse_ratios("0.95:1.05:0.01").unwrap().len(), 11);
    assert_eq!(parse_ratios("1:1:0.01").unwrap(), vec![1.0]);
    assert_eq!(parse_ratios("0.9:1.1:0.05").unwrap().len(), 5);
    assert!(parse_ratios("1.05:0.95:0.01").is_err());
}

/// `run --energy`: JSON with the contract fields on stdout, closing to 1e-9 of the input work
/// with the exact solver, and friction work of the sign its law dictates.
#[test]
fn run_energy_json_closes_and_has_the_friction_sign() {
    let dir = tempfile::tempdir().unwrap();
    for (friction, force, sign) in [
        ("as-published", "20", 1.0),
        ("coulomb", "0.0204", -1.0),
        ("none", "0", 0.0),
    ] {
        let out = dir.path().join(format!("{friction}.csv"));
        let o = vibrobar_ok(&[
            "run",
            "--preset",
            "paper",
            "--friction",
            friction,
            "--friction-force-n",
            force,
            "--gap-mm",
            "1",
            "--ratio",
            "1",
            "--duration",
            "0.2",
            "--solver",
            "exact",
            "--energy",
            "--out",
            out.to_str().unwrap(),
        ]);
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap_or_else(|e| {
            panic!(
                "stdout is not JSON ({e}):\n{}",
                String::from_utf8_lossy(&o.stdout)
            )
        });
        let f = |k: &str| {
            v[k].as_f64()
                .unwrap_or_else(|| panic!("{friction}: field {k} missing in {v}"))
        };
        let input = f("work_input_j");
        let closing = f("delta_mechanical_j")
            - (input - f("viscous_loss_j") - f("impact_loss_j") + f("friction_work_j"));
        assert!(
            (closing - f("residual_j")).abs() <= 1e-12 * input.abs(),
            "{friction}: residual field inconsistent"
        );
        assert!(
            f("residual_j").abs() <= 1e-9 * input.abs(),
            "{friction}: residual {} vs input {input}",
            f("residual_j")
        );
        let fw = f("friction_work_j");
        if sign == 0.0 {
            assert!(fw.abs() <= 0.0, "{friction}: friction work {fw}");
        } else {
            assert!(
                fw * sign > 0.0,
                "{friction}: friction work {fw} has the wrong sign"
            );
        }
        let meta =
            std::fs::read_to_string(dir.path().join(format!("{friction}.csv.meta.json"))).unwrap();
        assert!(
            meta.contains("\"fingerprint\"") && meta.contains("\"solver\": \"exact\""),
            "{meta}"
        );
    }
    no_partial_files(dir.path());
}

/// `run --out FILE.npy` writes an n × 7 float64 array with the same numbers as the CSV.
#[test]
fn run_writes_npy_matching_the_csv() {
    let dir = tempfile::tempdir().unwrap();
    let (c, n) = (dir.path().join("h.csv"), dir.path().join("h.npy"));
    for out in [&c, &n] {
        vibrobar_ok(&[
            "run",
            "--preset",
            "paper",
            "--gap-mm",
            "0.1",
            "--ratio",
            "1",
            "--duration",
            "0.01",
            "--sample-every",
            "100",
            "--out",
            out.to_str().unwrap(),
        ]);
    }
    let (_, rows) = csv(&c);
    let (shape, data) = vibrobar_io::npy::decode_f64(&std::fs::read(&n).unwrap(), "h.npy").unwrap();
    assert_eq!(shape, vec![rows.len(), 7]);
    for (i, row) in rows.iter().enumerate() {
        for (j, x) in row.iter().enumerate() {
            let a: f64 = x.parse().unwrap();
            let b = data[i * 7 + j];
            assert!(
                (a - b).abs() <= 1e-12 * b.abs().max(1e-12),
                "row {i} col {j}: csv {a} npy {b}"
            );
        }
    }
}

/// `beam` reaches the Euler–Bernoulli estimator: the closest reduction to the paper's solid bar
/// (total mass ρAL, K = Mω₁²) and a clean error for a bad length.
#[test]
fn beam_prints_every_reduction_and_rejects_bad_geometry() {
    let o = vibrobar_ok(&["beam"]);
    let text = String::from_utf8_lossy(&o.stdout);
    for r in [
        "static-rayleigh",
        "static-exact-freq",
        "modal-tip",
        "total-mass",
    ] {
        assert!(text.contains(r), "missing {r}:\n{text}");
    }
    let line = text.lines().find(|l| l.contains("total-mass")).unwrap();
    let nums: Vec<f64> = line
        .split_whitespace()
        .filter_map(|w| w.parse().ok())
        .collect();
    // ρAL = 7850·π·0.0125²·0.175 kg; K = ρAL·(1.8751²)²·EI/(ρA L⁴)
    let m = 7850.0 * std::f64::consts::PI * 0.0125f64.powi(2) * 0.175;
    let ei = 200e9 * std::f64::consts::PI * 0.025f64.powi(4) / 64.0;
    let k = 1.875_104_068_711_961f64.powi(4) * ei / 0.175f64.powi(3);
    assert!((nums[0] - m).abs() < 1e-4, "M {} vs {m}", nums[0]);
    assert!(
        (nums[1] - k * 1e-6).abs() < 1e-4,
        "K {} vs {}",
        nums[1],
        k * 1e-6
    );
    let bad = vibrobar(&["beam", "--length-mm", "-3"]);
    assert!(!bad.status.success());
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(err.contains("length_m") && err.contains("(0, ∞)"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}
