//! `vibrobar orbit` and `vibrobar continue` (issue #11): the output contracts, metadata, figure,
//! and the errors for a bad period, interval or parameter name.
mod common;

use common::{assert_fails_with, vibrobar, vibrobar_ok};

#[test]
fn orbit_writes_the_contract_json_with_metadata() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.json");
    let o = out.to_str().unwrap();
    vibrobar_ok(&[
        "orbit",
        "--preset",
        "paper",
        "--friction",
        "none",
        "--ratio",
        "1",
        "--gap-mm",
        "0.08",
        "--period",
        "1",
        "--out",
        o,
    ]);
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let rms = j["rms_m"].as_f64().unwrap();
    assert!((7.0e-6..8.0e-6).contains(&rms), "{rms}");
    assert_eq!(j["impacts_per_period"], 2);
    assert_eq!(j["stable"], true);
    let m = j["multipliers"].as_array().unwrap();
    assert_eq!(m.len(), 4);
    for l in m {
        let (re, im) = (l[0].as_f64().unwrap(), l[1].as_f64().unwrap());
        assert!(re.hypot(im) < 1.0);
    }
    assert_eq!(j["physical"]["confined"], true);
    assert!(dir.path().join("o.json.meta.json").exists());
}

#[test]
fn continue_writes_the_contract_csv_and_figure() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("b.csv");
    let o = out.to_str().unwrap();
    let run = vibrobar_ok(&[
        "continue",
        "--preset",
        "paper",
        "--friction",
        "none",
        "--ratio",
        "1",
        "--param",
        "gap-mm",
        "--from",
        "0.06",
        "--to",
        "0.12",
        "--out",
        o,
    ]);
    let text = std::fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "param,rms_m,max_abs_multiplier,stable,impacts_per_period,period,event"
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert!(rows.len() > 50);
    let torus: Vec<_> = rows.iter().filter(|r| r[6] == "torus").collect();
    assert_eq!(torus.len(), 1);
    let g: f64 = torus[0][0].parse().unwrap();
    assert!((0.094..0.096).contains(&g), "{g}");
    // Stable before the torus point, unstable after it.
    let first: f64 = rows[0][0].parse().unwrap();
    assert!((first - 0.06).abs() < 1e-12 && rows[0][3] == "true");
    assert_eq!(rows.last().unwrap()[3], "false");
    for f in ["b.png", "b.svg", "b.csv.meta.json"] {
        assert!(dir.path().join(f).exists(), "{f}");
    }
    assert!(String::from_utf8_lossy(&run.stdout).contains("torus at gap-mm = 0.0948"));
}

#[test]
fn bad_input_names_the_flag_and_its_range() {
    let dir = tempfile::tempdir().unwrap();
    let o = dir.path().join("x.json");
    let o = o.to_str().unwrap();
    let base = ["--preset", "paper", "--friction", "none", "--ratio", "1"];
    let orbit = |extra: &[&str]| {
        let mut a = vec!["orbit"];
        a.extend(base);
        a.extend(["--gap-mm", "0.08", "--out", o]);
        a.extend(extra);
        vibrobar(&a)
    };
    assert_fails_with(&orbit(&["--period", "0"]), &["--period", "[1, 64]"]);
    assert_fails_with(&orbit(&["--period", "1000000"]), &["--period", "[1, 64]"]);
    assert_fails_with(&orbit(&["--solver", "rk4"]), &["exact solver"]);
    let cont = |extra: &[&str]| {
        let mut a = vec!["continue"];
        a.extend(base);
        a.extend(["--out", o]);
        a.extend(extra);
        vibrobar(&a)
    };
    assert_fails_with(
        &cont(&["--param", "gap", "--from", "0.06", "--to", "0.1"]),
        &["--param must be one of ratio, gap-mm, friction-force-n, restitution"],
    );
    assert_fails_with(
        &cont(&[
            "--param",
            "cavity-position-mm",
            "--from",
            "10",
            "--to",
            "20",
        ]),
        &["N-mode bar"],
    );
    assert_fails_with(
        &cont(&["--param", "gap-mm", "--from", "0.06", "--to", "0.06"]),
        &["interval is empty"],
    );
    assert_fails_with(
        &cont(&["--param", "gap-mm", "--from", "0.06", "--to", "inf"]),
        &["--to"],
    );
    assert_fails_with(
        &cont(&["--param", "gap-mm", "--from", "0.06", "--to", "-1"]),
        &["--to", "gap"],
    );
    assert!(!dir.path().join("x.json").exists());
}

/// `vibrobar continue2`: the contract CSV, the figure, the curve through the one-parameter
/// detection at r = 1, and the errors naming the flag.
#[test]
fn continue2_writes_the_curve_and_refuses_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("c.csv");
    let o = out.to_str().unwrap();
    let base = [
        "continue2",
        "--preset",
        "paper",
        "--friction",
        "none",
        "--from-point",
        "ratio=1,gap-mm=0.0949",
        "--kind",
        "torus",
        "--ratios",
        "0.98:1.03",
        "--out",
        o,
    ];
    vibrobar_ok(&base);
    let text = std::fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "ratio,gap_mm,kind,rms_m,max_abs_multiplier,on_boundary,test_function,residual,impacts_per_period,event"
    );
    let rows: Vec<Vec<String>> = lines
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    assert!(rows.len() > 10);
    let num = |r: &Vec<String>, i: usize| r[i].parse::<f64>().unwrap();
    assert!((num(&rows[0], 0) - 0.98).abs() < 1e-12);
    assert!((num(rows.last().unwrap(), 0) - 1.03).abs() < 1e-12);
    for r in &rows {
        assert_eq!(r[2], "torus");
        assert!(num(r, 6).abs() < 1e-9 && num(r, 7) < 1e-9, "{r:?}");
    }
    // At r = 1 the curve passes the one-parameter torus point of the orbit-stability table
    // (0.09489 mm) and is the edge of stability there.
    let at1 = rows
        .iter()
        .find(|r| (num(r, 0) - 1.0).abs() < 1e-12)
        .unwrap();
    assert!((num(at1, 1) - 0.09489).abs() < 1e-5, "{at1:?}");
    assert_eq!(at1[5], "true");
    assert!(dir.path().join("c.png").exists() && dir.path().join("c.svg").exists());
    let with = |flag: &str, value: &str| -> Vec<String> {
        let mut v: Vec<String> = base.iter().map(|s| s.to_string()).collect();
        let i = v.iter().position(|a| a == flag).unwrap();
        v[i + 1] = value.into();
        v
    };
    for (flag, value, want) in [
        ("--kind", "hopf", "--kind"),
        ("--ratios", "1.02:1.02", "--ratios"),
        ("--ratios", "1.05:0.95", "--ratios"),
        ("--from-point", "ratio=1", "--from-point"),
        ("--from-point", "ratio=1,gap-mm=-0.1", "--from-point gap-mm"),
    ] {
        let args = with(flag, value);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        assert_fails_with(&vibrobar(&args), &[want]);
    }
    let mut args: Vec<&str> = base.to_vec();
    args.extend(["--gaps-mm", "0.2:0.1"]);
    assert_fails_with(&vibrobar(&args), &["--gaps-mm"]);
}

/// `--contact hertz` on the lumped bar (issue #11 through compliant contact phases): the orbit
/// is the restitution law's softened (RMS 6.87e-6 m against 7.43e-6 m, max |λ| 0.7288 against
/// 0.8469), the continuation in the gap finds the symmetric orbit's torus point (0.0854 mm,
/// against 0.0949 mm with the restitution law), and the spectrum reports the approach memory.
#[test]
fn hertz_orbit_continuation_and_spectrum() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.json");
    let base = [
        "--preset",
        "paper",
        "--friction",
        "none",
        "--ratio",
        "1",
        "--contact",
        "hertz",
    ];
    let mut args = vec!["orbit"];
    args.extend(base);
    args.extend([
        "--gap-mm",
        "0.08",
        "--period",
        "1",
        "--out",
        out.to_str().unwrap(),
    ]);
    vibrobar_ok(&args);
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let rms = j["rms_m"].as_f64().unwrap();
    assert!((6.5e-6..7.2e-6).contains(&rms), "{rms}");
    assert_eq!(j["impacts_per_period"], 2);
    assert_eq!(j["stable"], true);
    let mx = j["max_abs_multiplier"].as_f64().unwrap();
    assert!((mx - 0.7288).abs() < 1e-3, "{mx}");
    assert_eq!(j["physical"]["confined"], true);

    let csv = dir.path().join("b.csv");
    let mut args = vec!["continue"];
    args.extend(base);
    args.extend([
        "--param",
        "gap-mm",
        "--from",
        "0.06",
        "--to",
        "0.12",
        "--out",
        csv.to_str().unwrap(),
    ]);
    vibrobar_ok(&args);
    let text = std::fs::read_to_string(&csv).unwrap();
    let torus: Vec<f64> = text
        .lines()
        .filter(|l| l.ends_with(",torus"))
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect();
    assert!(
        torus.iter().any(|g| (0.083..0.088).contains(g)),
        "{torus:?}"
    );

    let mut args = vec!["lyapunov", "--spectrum", "--json", "--solver", "exact"];
    args.extend(base);
    args.extend(["--gap-mm", "0.08", "--duration", "0.3"]);
    let run = vibrobar_ok(&args);
    let j: serde_json::Value = serde_json::from_str(&String::from_utf8_lossy(&run.stdout)).unwrap();
    assert!(j["approach_memory_per_s"].as_f64().unwrap() > 100.0, "{j}");
    assert!(j["sum_per_s"].as_f64().unwrap() < 0.0, "{j}");
    assert!(
        j["events"]["compliant_contacts"].as_u64().unwrap() > 100,
        "{j}"
    );
}

/// The paper's 3-mode beam (`scenarios/paper_beam.toml`) and a 3-mode `[[modes]]` table:
/// `orbit` writes the contract keys with a modal state and a (2N+2)² monodromy; `continue`
/// follows the orbit in the cavity position (a `[beam]` only).
#[test]
fn modal_bars_have_orbits_and_branches_in_the_cavity_position() {
    let dir = tempfile::tempdir().unwrap();
    let beam = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenarios/paper_beam.toml"
    );
    let out = dir.path().join("o.json");
    let o = out.to_str().unwrap();
    let base = ["--scenario", beam, "--friction", "none", "--ratio", "1"];
    let mut a = vec!["orbit"];
    a.extend(base);
    a.extend(["--gap-mm", "0.1", "--out", o]);
    vibrobar_ok(&a);
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let n = j["modes"].as_u64().unwrap() as usize;
    assert!(n >= 2, "{j}");
    assert_eq!(j["state"]["q_m"].as_array().unwrap().len(), n);
    assert_eq!(j["multipliers"].as_array().unwrap().len(), 2 * n + 2);
    assert_eq!(j["monodromy"].as_array().unwrap().len(), 2 * n + 2);
    assert_eq!(j["impacts_per_period"], 2);
    assert!(j["rms_m"].as_f64().unwrap() > 0.0);
    assert!(j["residual"].as_f64().unwrap() <= 1e-9);
    assert_eq!(j["physical"]["confined"], true);
    assert!(j["stable"].is_boolean());
    let csv = dir.path().join("b.csv");
    let c = csv.to_str().unwrap();
    let mut a = vec!["continue"];
    a.extend(base);
    a.extend([
        "--gap-mm",
        "0.1",
        "--param",
        "cavity-position-mm",
        "--from",
        "137",
        "--to",
        "130",
        "--max-points",
        "40",
        "--out",
        c,
    ]);
    vibrobar_ok(&a);
    let text = std::fs::read_to_string(&csv).unwrap();
    let rows: Vec<Vec<&str>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert!(rows.len() >= 10);
    let first: f64 = rows[0][0].parse().unwrap();
    assert!((first - 137.0).abs() < 1e-9);
    let last: f64 = rows.last().unwrap()[0].parse().unwrap();
    assert!((130.0..137.0).contains(&last), "{last}");
    assert!(dir.path().join("b.png").exists() && dir.path().join("b.csv.meta.json").exists());
    // The cavity position needs a [beam]; the analytic start is the lumped bar's.
    let modes = dir.path().join("m.toml");
    let table = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenarios/measured_modes.toml"
    ))
    .unwrap();
    std::fs::write(&modes, &table[..table.find("\n[cutting]").unwrap()]).unwrap();
    let m = modes.to_str().unwrap();
    let mut a = vec![
        "continue",
        "--scenario",
        m,
        "--friction",
        "none",
        "--ratio",
        "1",
    ];
    a.extend([
        "--gap-mm",
        "0.1",
        "--param",
        "cavity-position-mm",
        "--from",
        "130",
    ]);
    a.extend(["--to", "120", "--out", c]);
    assert_fails_with(&vibrobar(&a), &["cavity-position-mm", "[beam]"]);
    let mut a = vec!["orbit"];
    a.extend(base);
    a.extend(["--gap-mm", "0.1", "--start", "symmetric", "--out", o]);
    assert_fails_with(&vibrobar(&a), &["--start symmetric", "settled"]);
    // The [[modes]] table at 0.06 mm: an unstable period-one orbit. (The settled run is
    // chaotic and passes near several: measured, a two-impact one with λ₁ = 7.2 from 0.35 and
    // 0.5 s, three-impact ones with λ₁ = 21.4, 13.3, −6.9 from 0.4, 0.45, 0.3 s; which one the
    // default settling time reaches depends on the run's last bits.)
    let mut a = vec![
        "orbit",
        "--scenario",
        m,
        "--friction",
        "none",
        "--ratio",
        "1",
    ];
    a.extend(["--gap-mm", "0.06", "--out", o]);
    vibrobar_ok(&a);
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(j["modes"], 3);
    assert!(j["impacts_per_period"].as_u64().unwrap() >= 2, "{j}");
    assert!(j["residual"].as_f64().unwrap() <= 1e-9);
    assert_eq!(j["physical"]["confined"], true);
    assert_eq!(j["stable"], false);
}

/// The lumped bar as one `[[modes]]` table (`f = √(K/M)/2π`, `M`, `ζ`, shape 1).
const ONE_UNIT_MODE: &str = "[[modes]]\nfrequency_hz = 602.2026447166344\ndamping_ratio = 0.01\nmodal_mass_kg = 0.644\nshape_cavity = 1.0\n";

/// `continue` on an N-mode bar switches to the period-2 branch at the period doubling of the
/// asymmetric orbit (0.050342 mm, the lumped bar's) unless `--no-switch`.
#[test]
fn modal_continue_switches_at_the_period_doubling_unless_no_switch() {
    let dir = tempfile::tempdir().unwrap();
    let sc = dir.path().join("one.toml");
    std::fs::write(&sc, ONE_UNIT_MODE).unwrap();
    let csv = dir.path().join("b.csv");
    let rows = |extra: &[&str]| -> Vec<(f64, u32, String)> {
        let mut a = vec![
            "continue",
            "--scenario",
            sc.to_str().unwrap(),
            "--friction",
            "none",
            "--ratio",
            "1",
            "--param",
            "gap-mm",
            "--from",
            "0.052",
            "--to",
            "0.0495",
            "--start",
            "settled",
            "--out",
            csv.to_str().unwrap(),
        ];
        a.extend(extra);
        let out = String::from_utf8_lossy(&vibrobar_ok(&a).stdout).into_owned();
        assert!(
            out.contains("period-doubling at gap-mm = 0.05034154"),
            "{out}"
        );
        std::fs::read_to_string(&csv)
            .unwrap()
            .lines()
            .skip(1)
            .map(|l| {
                let c: Vec<&str> = l.split(',').collect();
                (c[0].parse().unwrap(), c[5].parse().unwrap(), c[6].into())
            })
            .collect()
    };
    let sw = rows(&[]);
    let two: Vec<_> = sw.iter().filter(|r| r.1 == 2).collect();
    assert!(two.len() >= 3, "{sw:?}");
    assert!(two.iter().all(|r| (r.0 - 0.05034).abs() < 0.01));
    let pd: Vec<_> = sw.iter().filter(|r| r.2 == "period-doubling").collect();
    assert_eq!(pd.len(), 1);
    assert!((pd[0].0 - 0.0503415494).abs() < 1e-9, "{pd:?}");
    let plain = rows(&["--no-switch"]);
    assert!(plain.iter().all(|r| r.1 == 1) && plain.len() == sw.len() - two.len());
}

/// `continue2` on an N-mode bar: on the lumped bar as one `[[modes]]` table the README's torus
/// curve of the symmetric orbit (half map) passes the lumped curve's point at r = 1 (0.09489 mm)
/// and ends on the same box edges; on the 3-mode paper beam (`scenarios/paper_beam.toml`) the
/// period-doubling curve through the one-parameter `continue`'s detection at r = 1.02 (0.067364
/// mm) runs on the full map, every row on its test function's zero.
#[test]
fn continue2_runs_on_an_n_mode_bar() {
    let dir = tempfile::tempdir().unwrap();
    let sc = dir.path().join("one.toml");
    std::fs::write(&sc, ONE_UNIT_MODE).unwrap();
    let out = dir.path().join("c.csv");
    let rows = |args: &[&str]| -> (String, Vec<Vec<String>>) {
        let mut a = vec![
            "continue2",
            "--friction",
            "none",
            "--out",
            out.to_str().unwrap(),
        ];
        a.extend(args);
        let said = String::from_utf8_lossy(&vibrobar_ok(&a).stdout).into_owned();
        let text = std::fs::read_to_string(&out).unwrap();
        let rows = text
            .lines()
            .skip(1)
            .map(|l| l.split(',').map(String::from).collect())
            .collect();
        (said, rows)
    };
    let num = |r: &Vec<String>, i: usize| r[i].parse::<f64>().unwrap();
    let (said, one) = rows(&[
        "--scenario",
        sc.to_str().unwrap(),
        "--from-point",
        "ratio=1,gap-mm=0.09489",
        "--kind",
        "torus",
        "--ratios",
        "0.98:1.03",
    ]);
    assert!(said.contains("symmetric orbit, half map"), "{said}");
    assert!(one.len() > 10);
    assert!((num(&one[0], 0) - 0.98).abs() < 1e-12);
    assert!((num(one.last().unwrap(), 0) - 1.03).abs() < 1e-12);
    for r in &one {
        assert_eq!(r[2], "torus");
        assert!(num(r, 6).abs() < 1e-9 && num(r, 7) < 1e-9, "{r:?}");
    }
    let at1 = one
        .iter()
        .find(|r| (num(r, 0) - 1.0).abs() < 1e-12)
        .unwrap();
    assert!((num(at1, 1) - 0.09489).abs() < 1e-5, "{at1:?}");
    let beam = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenarios/paper_beam.toml"
    );
    let (said, b) = rows(&[
        "--scenario",
        beam,
        "--from-point",
        "ratio=1.02,gap-mm=0.0673636645425",
        "--kind",
        "period-doubling",
        "--ratios",
        "1.0:1.04",
        "--max-points",
        "5",
    ]);
    assert!(said.contains("full map"), "{said}");
    assert!(b.len() >= 8, "{said}");
    for r in &b {
        assert_eq!(r[2], "period-doubling");
        assert!(num(r, 6).abs() < 1e-8 && num(r, 7) < 1e-9, "{r:?}");
    }
    assert!(b.iter().any(|r| (num(r, 0) - 1.02).abs() < 1e-12));
}

/// Determinant by LU with partial pivoting.
#[allow(clippy::needless_range_loop)]
fn det(a: &[Vec<f64>]) -> f64 {
    let mut m = a.to_vec();
    let n = m.len();
    let mut d = 1.0;
    for k in 0..n {
        let p = (k..n)
            .max_by(|&i, &j| m[i][k].abs().total_cmp(&m[j][k].abs()))
            .unwrap();
        if p != k {
            m.swap(p, k);
            d = -d;
        }
        let piv = m[k][k];
        d *= piv;
        for i in k + 1..n {
            let f = m[i][k] / piv;
            for j in k..n {
                m[i][j] -= f * m[k][j];
            }
        }
    }
    d
}

/// `--contact hertz` on the paper's 3-mode beam (`scenarios/paper_beam.toml`): the N-mode bar's
/// variational flow through compliant contact phases. `orbit` finds the stable two-contact
/// orbit at r = 1, 0.1 mm; over a window of whole periods on it the spectrum's sum is
/// `ln|det J|/T` of its monodromy (measured 1e-12 apart: the attractor is that orbit, and the
/// determinant of the map over a whole period does not depend on the section phase); `continue`
/// in the gap finds the symmetry-breaking branch point (0.07775 mm), `continue2` follows the
/// torus curve through (r = 1, 0.069734 mm).
#[test]
fn hertz_on_a_beam_has_orbits_branches_curves_and_the_spectrum() {
    let dir = tempfile::tempdir().unwrap();
    let beam = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenarios/paper_beam.toml"
    );
    let base = [
        "--scenario",
        beam,
        "--friction",
        "none",
        "--contact",
        "hertz",
    ];
    let out = dir.path().join("o.json");
    let mut a = vec!["orbit"];
    a.extend(base);
    a.extend([
        "--ratio",
        "1",
        "--gap-mm",
        "0.1",
        "--out",
        out.to_str().unwrap(),
    ]);
    let said = String::from_utf8_lossy(&vibrobar_ok(&a).stdout).into_owned();
    assert!(said.contains("hertz contacts"), "{said}");
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let n = j["modes"].as_u64().unwrap() as usize;
    assert_eq!(n, 3);
    assert_eq!(j["impacts_per_period"], 2);
    assert_eq!(j["stable"], true);
    assert!(j["residual"].as_f64().unwrap() <= 1e-9, "{j}");
    assert_eq!(j["physical"]["confined"], true);
    let pen = j["physical"]["max_penetration_m"].as_f64().unwrap();
    assert!(pen > 0.0 && pen < 1e-5, "{pen}");
    let mono: Vec<Vec<f64>> = j["monodromy"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| {
            r.as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect()
        })
        .collect();
    assert_eq!(mono.len(), 2 * n + 2);
    let omega = j["parameters"]["damped_bar"]["modes"][0]["omega_rad_s"]
        .as_f64()
        .unwrap();
    let period = 2.0 * std::f64::consts::PI / omega;
    let want = det(&mono).abs().ln() / period;

    // The spectrum over 100 whole periods after 0.3 s.
    let duration = format!("{}", 0.3 + 100.0 * period);
    let mut a = vec!["lyapunov", "--spectrum", "--json", "--solver", "exact"];
    a.extend(base);
    a.extend([
        "--ratio",
        "1",
        "--gap-mm",
        "0.1",
        "--transient",
        "0.3",
        "--duration",
        &duration,
    ]);
    let run = vibrobar_ok(&a);
    let s: serde_json::Value = serde_json::from_str(&String::from_utf8_lossy(&run.stdout)).unwrap();
    let sum = s["sum_per_s"].as_f64().unwrap();
    eprintln!("Σλ {sum} vs ln|det J|/T {want}: {s}");
    assert_eq!(s["collapsed"], 0);
    assert_eq!(s["exponents_per_s"].as_array().unwrap().len(), 2 * n + 2);
    assert_eq!(s["events"]["compliant_contacts"], 200);
    assert_eq!(s["events"]["grazing"], 0);
    assert!(s["approach_memory_per_s"].as_f64().unwrap() > 100.0, "{s}");
    assert!(((sum - want) / want).abs() < 1e-9, "{sum} vs {want}");
    // The largest exponent tends to ln|λ₁|/T of the orbit's multiplier.
    let l1 = s["exponents_per_s"][0].as_f64().unwrap();
    let m1 = j["max_abs_multiplier"].as_f64().unwrap().ln() / period;
    assert!((l1 - m1).abs() < 0.05 * m1.abs(), "{l1} vs {m1}");

    let csv = dir.path().join("b.csv");
    let mut a = vec!["continue"];
    a.extend(base);
    a.extend([
        "--ratio",
        "1",
        "--param",
        "gap-mm",
        "--from",
        "0.085",
        "--to",
        "0.07",
        "--out",
        csv.to_str().unwrap(),
    ]);
    vibrobar_ok(&a);
    let text = std::fs::read_to_string(&csv).unwrap();
    let bp: Vec<f64> = text
        .lines()
        .filter(|l| l.ends_with(",branch-point"))
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect();
    assert!(bp.iter().any(|g| (g - 0.07775).abs() < 1e-4), "{bp:?}");

    let mut a = vec!["continue2"];
    a.extend(base);
    a.extend([
        "--from-point",
        "ratio=1,gap-mm=0.069733927992",
        "--kind",
        "torus",
        "--ratios",
        "0.998:1.002",
        "--max-points",
        "3",
        "--out",
        csv.to_str().unwrap(),
    ]);
    vibrobar_ok(&a);
    let rows: Vec<Vec<String>> = std::fs::read_to_string(&csv)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    assert!(rows.len() >= 5, "{rows:?}");
    for r in &rows {
        assert_eq!(r[2], "torus");
        let test: f64 = r[6].parse().unwrap();
        let residual: f64 = r[7].parse().unwrap();
        assert!(test.abs() < 1e-8 && residual < 1e-9, "{r:?}");
    }
}

/// A settled run where the ball floats without an impact (0.08 mm, r = 0.97): its orbits form
/// a continuum, which continuation cannot follow; refused, saying so, and nothing written.
#[test]
fn continuation_from_a_floating_ball_is_refused_with_the_reason() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("c.csv");
    let o = vibrobar(&[
        "continue",
        "--friction",
        "none",
        "--param",
        "ratio",
        "--from",
        "0.97",
        "--to",
        "1.03",
        "--gap-mm",
        "0.08",
        "--start",
        "settled",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_fails_with(&o, &["no impact", "the ball floats", "continuum"]);
    assert!(!out.exists());
}
