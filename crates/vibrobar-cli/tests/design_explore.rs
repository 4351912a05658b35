//! End-to-end tests of `poincare`, `bifurcation`, `lyapunov` and `ensemble` through the
//! `vibrobar` binary (short rk4 runs).

mod common;

use common::{assert_fails_with, assert_ok, bin, vibrobar};
use std::fs;

use vibrobar_io::npy::decode_f64;

/// CSV body as numbers.
fn numbers(path: &std::path::Path) -> (String, Vec<Vec<f64>>) {
    let text = fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().to_string();
    let rows = lines
        .map(|l| l.split(',').map(|x| x.parse::<f64>().unwrap()).collect())
        .collect();
    (header, rows)
}

#[test]
fn poincare_writes_csv_npy_and_figure_that_agree() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("p.csv");
    assert_ok(&vibrobar(&[
        "poincare",
        "--friction",
        "none",
        "--ratio",
        "1",
        "--gap-mm",
        "0.1",
        "--solver",
        "rk4",
        "--duration",
        "0.2",
        "--phase-deg",
        "90",
        "--out",
        out.to_str().unwrap(),
    ]));
    let (header, rows) = numbers(&out);
    assert_eq!(header, "t_s,u_m,du_m_s,w_m,dw_m_s");
    let (shape, data) = decode_f64(&fs::read(d.path().join("p.npy")).unwrap(), "p.npy").unwrap();
    assert_eq!(shape, vec![rows.len(), 5]);
    assert_eq!(data, rows.concat());
    // One point per forcing period after the transient (20 % of 0.2 s), at phase 90°:
    // Ω t_k = π/2 + 2πk.
    let omega = 1.0 * (9.22e6f64 / 0.644).sqrt();
    let period = 2.0 * std::f64::consts::PI / omega;
    let expected = ((0.2 - 0.04) / period).round() as i64;
    assert!(
        (rows.len() as i64 - expected).abs() <= 1,
        "{} vs {expected}",
        rows.len()
    );
    for w in rows.windows(2) {
        assert!((w[1][0] - w[0][0] - period).abs() < 1e-9);
    }
    for r in &rows {
        let phase = (omega * r[0]).rem_euclid(2.0 * std::f64::consts::PI);
        assert!(
            (phase - std::f64::consts::FRAC_PI_2).abs() < 1e-6,
            "{phase}"
        );
        assert!(r[0] >= 0.04);
    }
    assert!(fs::metadata(d.path().join("p.png")).unwrap().len() > 1000);
    assert!(d.path().join("p.svg").exists());
    assert!(d.path().join("p.csv.meta.json").exists());
}

#[test]
fn bifurcation_over_the_gap_writes_consistent_files() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("b.csv");
    assert_ok(&vibrobar(&[
        "bifurcation",
        "--friction",
        "none",
        "--param",
        "gap-mm",
        "--values",
        "0.1:0.3:0.1",
        "--ratio",
        "1",
        "--solver",
        "rk4",
        "--duration",
        "0.1",
        "--out",
        out.to_str().unwrap(),
    ]));
    let (header, rows) = numbers(&out);
    assert_eq!(header, "gap_mm,t_s,u_m,du_m_s");
    let mut params: Vec<f64> = rows.iter().map(|r| r[0]).collect();
    params.dedup();
    assert_eq!(params, vec![0.1, 0.2, 0.3]);
    let (shape, data) = decode_f64(&fs::read(d.path().join("b.npy")).unwrap(), "b.npy").unwrap();
    assert_eq!(shape, vec![rows.len(), 4]);
    assert_eq!(data, rows.concat());
    let imp = fs::read_to_string(d.path().join("b.impacts.csv")).unwrap();
    assert!(imp.starts_with("gap_mm,t_s,wall,dw_m_s\n"));
    assert!(d.path().join("b.png").exists());
    // The fixed parameter is required.
    let o = vibrobar(&[
        "bifurcation",
        "--friction",
        "none",
        "--param",
        "ratio",
        "--values",
        "0.9:1.1:0.1",
        "--solver",
        "rk4",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_fails_with(&o, &["--gap-mm is required"]);
}

#[test]
fn lyapunov_json_and_text() {
    let args = [
        "lyapunov",
        "--friction",
        "none",
        "--ratio",
        "1.2",
        "--gap-mm",
        "1",
        "--solver",
        "rk4",
        "--duration",
        "0.3",
    ];
    let o = vibrobar(&[&args[..], &["--json"]].concat());
    assert_ok(&o);
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let l = j["exponent_per_s"].as_f64().unwrap();
    assert!(l.is_finite());
    assert!(j["std_error_per_s"].as_f64().unwrap() >= 0.0);
    assert!(j["intervals"].as_u64().unwrap() >= 2);
    let o = vibrobar(&args);
    assert_ok(&o);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.starts_with("λ = ") && text.contains(" ± "), "{text}");
    // Too short for two intervals: a clear error.
    let o = vibrobar(&[&args[..9], &["--duration", "0.01", "--periods", "100"]].concat());
    assert_fails_with(&o, &["--duration"]);
}

/// `lyapunov --spectrum`: every exponent; the frictionless identity is printed beside the sum and
/// agrees with it; the two-trajectory output is unchanged without the flag.
#[test]
fn lyapunov_spectrum_json_and_text() {
    // The symmetric two-impact orbit (0.08 mm, r = 1): no wall contact, four finite exponents.
    let args = [
        "lyapunov",
        "--friction",
        "none",
        "--ratio",
        "1",
        "--gap-mm",
        "0.08",
        "--solver",
        "exact",
        "--duration",
        "1",
        "--spectrum",
    ];
    let o = vibrobar(&[&args[..], &["--json"]].concat());
    assert_ok(&o);
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let l: Vec<f64> = j["exponents_per_s"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert_eq!(l.len(), 4);
    assert!(l[0] < 0.0, "a stable orbit: {l:?}");
    let (sum, id) = (
        j["sum_per_s"].as_f64().unwrap(),
        j["volume_identity_per_s"].as_f64().unwrap(),
    );
    assert!((sum - l.iter().sum::<f64>()).abs() < 1e-9 * sum.abs());
    assert!((sum - id).abs() < 1e-9 * id.abs(), "{sum} vs {id}");
    assert_eq!(j["collapsed"].as_u64(), Some(0));
    assert!(j["events"]["impacts"].as_u64().unwrap() > 100);
    let o = vibrobar(&args);
    assert_ok(&o);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.starts_with("λ = [") && text.contains("Σλ"), "{text}");
    // The paper's 0.1 mm point rides the walls: two directions collapse, reported as −∞/null.
    let mut wall = args.to_vec();
    wall[6] = "0.1";
    let o = vibrobar(&[&wall[..], &["--json"]].concat());
    assert_ok(&o);
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["collapsed"].as_u64(), Some(2));
    assert!(j["exponents_per_s"][3].is_null() && j["exponents_per_s"][0].as_f64().unwrap() > 0.0);
    // rk4 cannot give saltation matrices; a modal bar or the Hertz law are refused by the core.
    let mut rk = args.to_vec();
    rk[8] = "rk4";
    assert_fails_with(&vibrobar(&rk), &["--spectrum needs --solver exact"]);
}

/// `lyapunov --spectrum` on the paper's beam (`[beam]`, N modes): 2N + 2 exponents whose sum
/// is the frictionless modal identity −Σcₙ/mₙ + 2 ln(e) × impacts/s.
#[test]
fn lyapunov_spectrum_of_a_beam() {
    let beam = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenarios/paper_beam.toml"
    );
    let o = vibrobar(&[
        "lyapunov",
        "--scenario",
        beam,
        "--friction",
        "none",
        "--ratio",
        "1",
        "--gap-mm",
        "0.08",
        "--duration",
        "0.5",
        "--spectrum",
        "--json",
    ]);
    assert_ok(&o);
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let l = j["exponents_per_s"].as_array().unwrap();
    assert!(l.len() >= 6 && l.len() % 2 == 0, "{l:?}");
    let (sum, id) = (
        j["sum_per_s"].as_f64().unwrap(),
        j["volume_identity_per_s"].as_f64().unwrap(),
    );
    assert!((sum - id).abs() < 1e-9 * id.abs(), "{sum} vs {id}");
    assert!(j["events"]["impacts"].as_u64().unwrap() > 100);
}

#[test]
fn ensemble_counts_members_and_is_reproducible() {
    let d = tempfile::tempdir().unwrap();
    let out = |n: &str| d.path().join(n);
    let args = |o: &str, seed: &str| -> Vec<String> {
        [
            "ensemble",
            "--friction",
            "none",
            "--ratios",
            "0.99:1.01:0.01",
            "--gap-mm",
            "0.1",
            "--members",
            "4",
            "--seed",
            seed,
            "--solver",
            "rk4",
            "--duration",
            "0.05",
            "--out",
            o,
        ]
        .iter()
        .map(|s| s.to_string())
        .collect()
    };
    let a = out("a.csv");
    let b = out("b.csv");
    assert_ok(
        &bin()
            .args(args(a.to_str().unwrap(), "7"))
            .env("RAYON_NUM_THREADS", "1")
            .output()
            .unwrap(),
    );
    assert_ok(
        &bin()
            .args(args(b.to_str().unwrap(), "7"))
            .env("RAYON_NUM_THREADS", "2")
            .output()
            .unwrap(),
    );
    assert_eq!(fs::read(&a).unwrap(), fs::read(&b).unwrap());
    let text = fs::read_to_string(&a).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("ratio,gap_mm,members,mean_rms_m,std_rms_m,min_rms_m,max_rms_m,regimes")
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 3);
    for r in rows {
        assert_eq!(r[2], "4");
        let n: usize = r[7]
            .split(';')
            .map(|c| c.rsplit_once(':').unwrap().1.parse::<usize>().unwrap())
            .sum();
        assert_eq!(n, 4, "regime counts {}", r[7]);
        let (mean, min, max): (f64, f64, f64) = (
            r[3].parse().unwrap(),
            r[5].parse().unwrap(),
            r[6].parse().unwrap(),
        );
        assert!(min <= mean && mean <= max);
    }
    // Another seed, other initial conditions.
    let c = out("c.csv");
    assert_ok(&bin().args(args(c.to_str().unwrap(), "8")).output().unwrap());
    assert_ne!(fs::read(&a).unwrap(), fs::read(&c).unwrap());
}
