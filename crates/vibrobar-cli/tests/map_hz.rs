//! `map --freqs-hz`: both bars at the same absolute frequency, through the `vibrobar` binary,
//! on the paper preset (damped bar M = 0.644 kg, K = 9.22e6 N/m; solid 0.668 kg, 9.26e6 N/m: the
//! two ω₁ differ, so a ratio of each bar's own ω₁ is another frequency).

mod common;

use common::{assert_fails_with, assert_ok, s, vibrobar_env};
use std::fs;
use std::path::{Path, PathBuf};
use vibrobar_core::analysis::Batch;
use vibrobar_core::solver::solver_by_name;
use vibrobar_scenario::Scenario;

const FREQS: &str = "590:600:5";
const FREQS_HZ: [f64; 3] = [590.0, 595.0, 600.0];

fn common_args<'a>(out: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut v = vec![
        "--preset",
        "paper",
        "--friction",
        "none",
        "--solver",
        "rk4",
        "--duration",
        "0.05",
        "--out",
        out,
    ];
    v.extend_from_slice(extra);
    v
}

fn map_hz<'a>(out: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut v = vec!["map", "--freqs-hz", FREQS, "--gaps-mm", "0.1:0.2:0.1"];
    v.extend(common_args(out, extra));
    v
}

fn rows(path: &Path) -> Vec<Vec<String>> {
    fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(String::from).collect())
        .collect()
}

fn meta(path: &Path) -> serde_json::Value {
    serde_json::from_str(&fs::read_to_string(format!("{}.meta.json", s(path))).unwrap()).unwrap()
}

fn num(x: &str) -> f64 {
    x.parse().unwrap()
}

fn p(dir: &Path, name: &str) -> PathBuf {
    dir.join(name)
}

#[test]
fn map_in_hz_runs_the_solid_bar_at_the_same_frequency_as_the_sweep() {
    let d = tempfile::tempdir().unwrap();
    let map = p(d.path(), "m.csv");
    assert_ok(&vibrobar_env(&map_hz(s(&map), &[]), &[]));
    let sweep = p(d.path(), "s.csv");
    let mut a = vec!["sweep", "--freqs-hz", FREQS, "--gap-mm", "0.1,0.2"];
    a.extend(common_args(s(&sweep), &[]));
    assert_ok(&vibrobar_env(&a, &[]));
    let (m, sw) = (rows(&map), rows(&sweep));
    // map: ratio-major (ratio, gap_mm, rms_solid_m, rms_damped_m, …); sweep: gap-major
    // (ratio, gap_mm, friction, solver, rms_solid_m, rms_damped_m, …).
    assert_eq!(m.len(), 6);
    assert_eq!(sw.len(), 6);
    for (i, row) in m.iter().enumerate() {
        let (r, g) = (i / 2, i % 2);
        let srow = &sw[g * 3 + r];
        // Both the damped bar's Ω/ω₁ (the map prints 12 digits, the sweep 9).
        assert!(
            (num(&row[0]) - num(&srow[0])).abs() < 1e-9,
            "ratio, row {i}"
        );
        assert_eq!(row[1], srow[1], "gap column, row {i}");
        assert_eq!(
            num(&row[2]).to_bits(),
            num(&srow[4]).to_bits(),
            "solid RMS, row {i}"
        );
        assert_eq!(
            num(&row[3]).to_bits(),
            num(&srow[5]).to_bits(),
            "damped RMS, row {i}"
        );
    }
    // The solid RMS is that of the solid bar at its own ratio of the same Ω, not at the damped
    // bar's ratio (the `ratio` column), which would be another frequency.
    let mut sc = Scenario::paper();
    sc.run.settings.duration_s = 0.05;
    let base = sc.base().unwrap();
    let settings = sc.settings();
    let solver = solver_by_name("rk4", &settings).unwrap();
    let batch = Batch::new(&base, &settings, solver.as_ref());
    for (k, f) in FREQS_HZ.iter().enumerate() {
        let w = 2.0 * std::f64::consts::PI * f;
        let (rd, rs) = (
            w / base.damped_bar.omega1_rad_s(),
            w / base.solid_bar.omega1_rad_s(),
        );
        assert!((rd - rs).abs() > 1e-3);
        let row = &m[2 * k];
        assert!((num(&row[0]) - rd).abs() < 1e-9, "{f} Hz: ratio {}", row[0]);
        let at_own = batch.solid(rs).unwrap().rms_m;
        let at_damped_ratio = batch.solid(rd).unwrap().rms_m;
        assert_eq!(num(&row[2]).to_bits(), at_own.to_bits(), "{f} Hz");
        assert_ne!(num(&row[2]), at_damped_ratio, "{f} Hz");
    }
    // The header is the map's usual one; the frequencies are in the metadata.
    let header = fs::read_to_string(&map).unwrap();
    assert!(header.starts_with(
        "ratio,gap_mm,rms_solid_m,rms_damped_m,reduction_pct,impacts_per_cycle,regime\n"
    ));
    let mm = meta(&map);
    assert_eq!(
        mm["parameters"]["frequencies_hz"],
        serde_json::json!(FREQS_HZ)
    );
    assert_eq!(mm["parameters"]["grid"]["freqs_hz"], FREQS);
    assert!(mm["parameters"]["grid"].get("ratios").is_none());
    assert!(p(d.path(), "m.optimum.csv").exists());
}

#[test]
fn map_in_hz_shards_merge_and_resume_byte_for_byte() {
    let d = tempfile::tempdir().unwrap();
    let full = p(d.path(), "full/m.csv");
    assert_ok(&vibrobar_env(&map_hz(s(&full), &[]), &[]));
    let mut shards = Vec::new();
    for k in 1..=2 {
        let f = p(d.path(), &format!("shards/m.{k}.csv"));
        let spec = format!("{k}/2");
        assert_ok(&vibrobar_env(&map_hz(s(&f), &["--shard", &spec]), &[]));
        assert_eq!(meta(&f)["fingerprint"], meta(&full)["fingerprint"]);
        shards.push(f);
    }
    let merged = p(d.path(), "merged/m.csv");
    assert_ok(&vibrobar_env(
        &["merge", "--out", s(&merged), s(&shards[1]), s(&shards[0])],
        &[],
    ));
    assert_eq!(fs::read(&merged).unwrap(), fs::read(&full).unwrap());
    assert_eq!(
        meta(&merged)["parameters"]["frequencies_hz"],
        serde_json::json!(FREQS_HZ)
    );
    // A shard of the same grid in ratios is another job: its solid runs are other frequencies.
    let ratios = p(d.path(), "ratios/m.2.csv");
    assert_ok(&vibrobar_env(
        &[
            "map",
            "--ratios",
            "1:1.02:0.01",
            "--gaps-mm",
            "0.1:0.2:0.1",
            "--shard",
            "2/2",
        ]
        .into_iter()
        .chain(common_args(s(&ratios), &[]))
        .collect::<Vec<_>>(),
        &[],
    ));
    assert_ne!(meta(&ratios)["fingerprint"], meta(&full)["fingerprint"]);
    let o = vibrobar_env(
        &[
            "merge",
            "--out",
            s(&p(d.path(), "x.csv")),
            s(&shards[0]),
            s(&ratios),
        ],
        &[],
    );
    assert_fails_with(&o, &["another job"]);
    // Resume from a journal holding part of the rows.
    let fingerprint = meta(&full)["fingerprint"].as_str().unwrap().to_string();
    let lines: Vec<String> = fs::read_to_string(&full)
        .unwrap()
        .lines()
        .map(str::to_string)
        .collect();
    let out = p(d.path(), "part/m.csv");
    fs::create_dir_all(out.parent().unwrap()).unwrap();
    let mut j = format!(
        "# vibrobar journal v1 fingerprint={fingerprint}\nindex,{}\n",
        lines[0]
    );
    for i in [4usize, 1] {
        j.push_str(&format!("{i},{}\n", lines[1 + i]));
    }
    fs::write(format!("{}.journal", s(&out)), j).unwrap();
    assert_ok(&vibrobar_env(&map_hz(s(&out), &["--resume"]), &[]));
    assert_eq!(fs::read(&out).unwrap(), fs::read(&full).unwrap());
}

#[test]
fn map_in_hz_bad_input_names_the_flag_and_its_range() {
    let d = tempfile::tempdir().unwrap();
    let out = p(d.path(), "x.csv");
    // `map` with these frequency flags on a one-gap grid.
    let map = |freq: &[&str]| {
        let mut a = vec!["map"];
        a.extend_from_slice(freq);
        a.extend([
            "--gaps-mm",
            "0.1:0.1:0.1",
            "--friction",
            "none",
            "--out",
            s(&out),
        ]);
        vibrobar_env(&a, &[])
    };
    let both = map(&["--ratios", "1:1:1", "--freqs-hz", FREQS]);
    assert_fails_with(&both, &["--ratios", "--freqs-hz"]);
    assert_fails_with(&map(&[]), &["--ratios", "--freqs-hz"]);
    for (spec, want) in [
        ("-600:600:10", "START in (0, 1e7] Hz"),
        ("0:600:10", "START in (0, 1e7] Hz"),
        ("500:600:0", "STEP in (0, ∞) Hz"),
        ("500:600:-1", "STEP in (0, ∞) Hz"),
        ("600:500:10", "STOP in [START, 1e7] Hz"),
        ("1:1e7:0.001", "frequency lines"),
        ("1:2:x", "STEP must be a number"),
        ("1:2", "START:STOP:STEP"),
        ("nan:600:1", "--freqs-hz"),
    ] {
        assert_fails_with(&map(&["--freqs-hz", spec]), &["--freqs-hz", want]);
    }
    assert!(!out.exists());
}
