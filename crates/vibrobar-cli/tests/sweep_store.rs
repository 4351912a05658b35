//! `vibrobar sweep` through the row journal: interrupted and resumed sweeps give the same bytes,
//! torn journal lines are dropped, metadata is written, the thread count does not matter.

mod common;

use common::{assert_fails_with, assert_ok, bin, vibrobar_env};
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Stdio;

const HEADER: &str = "ratio,gap_mm,friction,solver,rms_solid_m,rms_damped_m,reduction_pct,impacts";

/// 2 gaps × 21 ratios of 0.2 s rk4 runs (rk4: slow enough to be killed part-way).
fn args(out: &Path, extra: &[&str]) -> Vec<String> {
    let mut v: Vec<String> = [
        "sweep",
        "--preset",
        "paper",
        "--friction",
        "none",
        "--gap-mm",
        "0.1,0.3",
        "--ratios",
        "0.95:1.05:0.005",
        "--solver",
        "rk4",
        "--duration",
        "0.2",
        "--out",
        out.to_str().unwrap(),
    ]
    .iter()
    .map(|x| x.to_string())
    .collect();
    v.extend(extra.iter().map(|x| x.to_string()));
    v
}

fn journal_of(out: &Path) -> PathBuf {
    PathBuf::from(format!("{}.journal", out.display()))
}

fn meta_of(out: &Path) -> serde_json::Value {
    let text = fs::read_to_string(format!("{}.meta.json", out.display())).expect("meta file");
    serde_json::from_str(&text).unwrap()
}

#[test]
fn sweep_rows_are_gap_major_with_metadata_and_independent_of_threads() {
    let d = tempfile::tempdir().unwrap();
    let one = d.path().join("one/s.csv");
    let two = d.path().join("two/s.csv");
    assert_ok(&vibrobar_env(
        &args(&one, &[]),
        &[("RAYON_NUM_THREADS", "1")],
    ));
    assert_ok(&vibrobar_env(
        &args(&two, &[]),
        &[("RAYON_NUM_THREADS", "2")],
    ));
    assert_eq!(fs::read(&one).unwrap(), fs::read(&two).unwrap());
    let text = fs::read_to_string(&one).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some(HEADER));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 42);
    for (i, r) in rows.iter().enumerate() {
        let gap: f64 = r[1].parse().unwrap();
        let ratio: f64 = r[0].parse().unwrap();
        assert!(
            (gap - [0.1, 0.3][i / 21]).abs() < 1e-12,
            "row {i}: gap {gap}"
        );
        assert!(
            (ratio - (0.95 + 0.005 * (i % 21) as f64)).abs() < 1e-9,
            "row {i}: ratio {ratio}"
        );
    }
    assert!(!journal_of(&one).exists());
    let m = meta_of(&one);
    assert_eq!(m["kind"], "sweep");
    assert_eq!(m["header"], HEADER);
    let fp = m["fingerprint"].as_str().unwrap();
    assert_eq!(fp.len(), 16, "{fp}");
    assert_eq!(m["fingerprint"], meta_of(&two)["fingerprint"]);
    assert_eq!(m["parameters"]["solver"], "rk4");
    assert_eq!(m["parameters"]["settings"]["duration_s"], 0.2);
    assert_eq!(m["parameters"]["gaps_m"].as_array().unwrap().len(), 2);
    assert_eq!(m["parameters"]["ratios"].as_array().unwrap().len(), 21);
    assert_eq!(m["parameters"]["scenario"]["damper"]["friction"], "none");
    assert!(m["version"].as_str().is_some_and(|v| !v.is_empty()));
    assert!(m["created_utc"].as_str().is_some_and(|v| v.ends_with('Z')));
    assert_eq!(m["grid"]["total"], 42);
}

#[test]
fn sweep_killed_then_resumed_is_byte_identical() {
    let d = tempfile::tempdir().unwrap();
    let full = d.path().join("full/s.csv");
    assert_ok(&vibrobar_env(&args(&full, &[]), &[]));
    let out = d.path().join("killed/s.csv");
    let mut child = bin()
        .args(args(&out, &[]))
        .env("RAYON_NUM_THREADS", "1")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let jp = journal_of(&out);
    let t0 = std::time::Instant::now();
    loop {
        let rows = fs::read_to_string(&jp)
            .map(|t| t.lines().count().saturating_sub(2))
            .unwrap_or(0);
        if rows >= 3 || t0.elapsed().as_secs() > 120 {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    if out.exists() {
        eprintln!("the sweep finished before it could be killed; only the resume path is tested");
    } else {
        let rows = fs::read_to_string(&jp).unwrap().lines().count() - 2;
        assert!((3..42).contains(&rows), "{rows} rows in the journal");
        // Without --resume an existing journal is a clear error, and nothing is overwritten.
        let o = vibrobar_env(&args(&out, &[]), &[]);
        assert!(!o.status.success());
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains("--resume"), "{err}");
        assert!(!out.exists());
        assert_ok(&vibrobar_env(&args(&out, &["--resume"]), &[]));
    }
    assert_eq!(fs::read(&out).unwrap(), fs::read(&full).unwrap());
    assert!(!jp.exists());
    assert_eq!(meta_of(&out)["fingerprint"], meta_of(&full)["fingerprint"]);
}

#[test]
fn sweep_resume_drops_a_torn_journal_line_and_refuses_other_parameters() {
    let d = tempfile::tempdir().unwrap();
    let full = d.path().join("full/s.csv");
    assert_ok(&vibrobar_env(&args(&full, &[]), &[]));
    let fp = meta_of(&full)["fingerprint"].as_str().unwrap().to_string();
    let rows: Vec<String> = fs::read_to_string(&full)
        .unwrap()
        .lines()
        .skip(1)
        .map(str::to_string)
        .collect();
    let out = d.path().join("part/s.csv");
    fs::create_dir_all(out.parent().unwrap()).unwrap();
    let mut j = format!("# vibrobar journal v1 fingerprint={fp}\nindex,{HEADER}\n");
    for i in [30usize, 2, 21, 0, 41] {
        j.push_str(&format!("{i},{}\n", rows[i]));
    }
    // Torn last line, as a kill in the middle of a write leaves it (a wrong value on purpose:
    // if it were kept, the result would differ).
    j.push_str("9,0.99,0.1,none,rk4,9.9e-9");
    fs::write(journal_of(&out), j).unwrap();
    assert_ok(&vibrobar_env(&args(&out, &["--resume"]), &[]));
    assert_eq!(fs::read(&out).unwrap(), fs::read(&full).unwrap());
    // A journal of other parameters (another duration) is refused.
    let other = d.path().join("other/s.csv");
    fs::create_dir_all(other.parent().unwrap()).unwrap();
    fs::write(
        journal_of(&other),
        format!("# vibrobar journal v1 fingerprint={fp}\nindex,{HEADER}\n"),
    )
    .unwrap();
    let mut a = args(&other, &["--resume"]);
    let k = a.iter().position(|x| x == "0.2").unwrap();
    a[k] = "0.1".into();
    let o = vibrobar_env(&a, &[]);
    assert_fails_with(&o, &["different parameters"]);
    assert!(!other.exists());
}
