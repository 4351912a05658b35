//! End-to-end tests of `placement` (and `merge` of its shards) through the `vibrobar` binary, on
//! tiny grids with short rk4 runs.

mod common;

use common::{assert_fails_with, assert_ok, s, vibrobar_env};
use std::fs;
use std::path::{Path, PathBuf};

const HEADER: &str = "position_mm,gap_mm,mean_reduction_pct,worst_rms_m,worst_ratio,\
                      min_reduction_pct,mean_impacts_per_cycle,regime";

/// The paper's bar as a beam: 3 positions × 2 gaps over 2 ratios, 0.03 s runs with rk4.
fn args<'a>(out: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut v = vec![
        "placement",
        "--friction",
        "none",
        "--positions-mm",
        "125:175:25",
        "--gaps-mm",
        "0.1:0.2:0.1",
        "--ratios",
        "0.98:1.02:0.04",
        "--solver",
        "rk4",
        "--duration",
        "0.03",
        "--out",
        out,
    ];
    v.extend_from_slice(extra);
    v
}

fn p(dir: &Path, name: &str) -> PathBuf {
    dir.join(name)
}

fn journal_of(out: &Path) -> PathBuf {
    PathBuf::from(format!("{}.journal", s(out)))
}

#[test]
fn placement_writes_the_contract_header_one_row_per_point_metadata_and_figure() {
    let d = tempfile::tempdir().unwrap();
    let out = p(d.path(), "p.csv");
    let o = vibrobar_env(&args(s(&out), &[]), &[]);
    assert_ok(&o);
    let text = fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some(HEADER));
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), 6);
    // Position outer, gap inner, in mm from the clamp.
    for (row, key) in rows.iter().zip([
        "125,0.1,", "125,0.2,", "150,0.1,", "150,0.2,", "175,0.1,", "175,0.2,",
    ]) {
        assert!(row.starts_with(key), "{row}");
    }
    let meta: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(p(d.path(), "p.csv.meta.json")).unwrap()).unwrap();
    assert_eq!(meta["kind"], "placement");
    assert_eq!(meta["header"], HEADER);
    assert_eq!(meta["parameters"]["positions_m"][2], 0.175);
    assert!(p(d.path(), "p.reduction.png").exists());
    assert!(p(d.path(), "p.reduction.svg").exists());
    assert!(!journal_of(&out).exists());
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("optimum: cavity at"), "{stdout}");
    assert!(
        stdout.contains("nodes of mode 2 of the damped bar: 137.10 mm"),
        "{stdout}"
    );
}

#[test]
fn two_shards_merged_equal_the_unsharded_study_byte_for_byte() {
    let d = tempfile::tempdir().unwrap();
    let full = p(d.path(), "full/p.csv");
    assert_ok(&vibrobar_env(&args(s(&full), &[]), &[]));
    let mut shards = Vec::new();
    for k in 1..=2 {
        let f = p(d.path(), &format!("shards/p.{k}.csv"));
        let spec = format!("{k}/2");
        assert_ok(&vibrobar_env(&args(s(&f), &["--shard", &spec]), &[]));
        shards.push(f);
    }
    assert!(!p(d.path(), "shards/p.1.reduction.png").exists());
    let merged = p(d.path(), "merged/p.csv");
    assert_ok(&vibrobar_env(
        &["merge", "--out", s(&merged), s(&shards[1]), s(&shards[0])],
        &[],
    ));
    assert_eq!(fs::read(&merged).unwrap(), fs::read(&full).unwrap());
    assert!(p(d.path(), "merged/p.reduction.png").exists());
    let o = vibrobar_env(
        &["merge", "--out", s(&p(d.path(), "x.csv")), s(&shards[0])],
        &[],
    );
    assert_fails_with(&o, &["missing shards [2]"]);
}

#[test]
fn resume_after_an_interruption_is_byte_identical() {
    let d = tempfile::tempdir().unwrap();
    let full = p(d.path(), "full/p.csv");
    assert_ok(&vibrobar_env(&args(s(&full), &[]), &[]));
    let fingerprint = {
        let m: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(p(d.path(), "full/p.csv.meta.json")).unwrap())
                .unwrap();
        m["fingerprint"].as_str().unwrap().to_string()
    };
    let rows: Vec<String> = fs::read_to_string(&full)
        .unwrap()
        .lines()
        .skip(1)
        .map(str::to_string)
        .collect();
    // A journal as a killed run leaves it: rows in completion order, a torn last line.
    let out = p(d.path(), "part/p.csv");
    fs::create_dir_all(out.parent().unwrap()).unwrap();
    let mut j = format!("# vibrobar journal v1 fingerprint={fingerprint}\nindex,{HEADER}\n");
    for i in [4usize, 1] {
        j.push_str(&format!("{i},{}\n", rows[i]));
    }
    j.push_str(&format!("3,{}", &rows[3][..rows[3].len() / 2]));
    fs::write(journal_of(&out), j).unwrap();
    let o = vibrobar_env(&args(s(&out), &[]), &[]);
    assert_fails_with(&o, &["--resume"]);
    assert!(!out.exists());
    assert_ok(&vibrobar_env(&args(s(&out), &["--resume"]), &[]));
    assert_eq!(fs::read(&out).unwrap(), fs::read(&full).unwrap());
    assert!(!journal_of(&out).exists());
}

#[test]
fn bad_input_names_the_flag_and_its_range() {
    let d = tempfile::tempdir().unwrap();
    let out = p(d.path(), "p.csv");
    let with = |flag: &str, value: &str| -> Vec<String> {
        let mut v: Vec<String> = args(s(&out), &[]).iter().map(|x| x.to_string()).collect();
        let i = v.iter().position(|x| x == flag).unwrap();
        v[i + 1] = value.into();
        v
    };
    for (flag, value, want) in [
        (
            "--positions-mm",
            "150:200:25",
            "--positions-mm: value 200 is outside the allowed range [0, 175] mm",
        ),
        ("--positions-mm", "-10:0:10", "[0, 175] mm"),
        ("--positions-mm", "150:100:25", "below START"),
        ("--gaps-mm", "0:0.1:0.1", "--gaps-mm: value 0 is outside"),
        ("--ratios", "1:0.9:0.1", "--ratios: STOP"),
        ("--solver", "euler", "--solver"),
    ] {
        let o = vibrobar_env(&with(flag, value), &[]);
        let err = assert_fails_with(&o, &[]);
        assert!(err.contains(want), "{flag} {value}: {err}");
        assert!(!out.exists() && !journal_of(&out).exists());
    }
    // A lumped scenario (no [beam]) has no positions.
    let sc = p(d.path(), "lumped.toml");
    fs::write(&sc, "[bar]\ndamping_ratio = 0.02\n").unwrap();
    let mut v: Vec<String> = args(s(&out), &[]).iter().map(|x| x.to_string()).collect();
    v.extend(["--scenario".into(), s(&sc).into()]);
    let o = vibrobar_env(&v, &[]);
    assert_fails_with(&o, &["no [beam] section", "--scenario"]);
    // A cavity section narrows the range to the hole inside the bar.
    let holed = p(d.path(), "holed.toml");
    fs::write(
        &holed,
        "[beam]\ncavity_section = { hole_diameter_m = 0.018, length_m = 0.012 }\n",
    )
    .unwrap();
    let mut v = with("--positions-mm", "150:175:25");
    v.extend(["--scenario".into(), s(&holed).into()]);
    let o = vibrobar_env(&v, &[]);
    assert_fails_with(&o, &["--positions-mm", "[9, 166] mm"]);
}

#[test]
fn bench_prints_the_beam_rows_and_the_placement_projection() {
    let o = vibrobar_env(
        &["bench", "--solvers", "rk4,exact", "--duration", "0.01"],
        &[],
    );
    assert_ok(&o);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("4-mode beam"), "{out}");
    assert!(
        out.contains("rk4    beam run, none:") && out.contains("alternating pairs"),
        "{out}"
    );
    assert!(
        out.contains("exact  beam run, as-published:") && out.contains("median ratio"),
        "{out}"
    );
    assert!(
        out.contains("projected 50×50 positions × gaps over 11 ratios (27511 runs)"),
        "{out}"
    );
}

#[test]
fn results_do_not_depend_on_the_thread_count_and_a_cavity_section_runs_fe_models() {
    let d = tempfile::tempdir().unwrap();
    let (a, b) = (p(d.path(), "a.csv"), p(d.path(), "b.csv"));
    assert_ok(&vibrobar_env(&args(s(&a), &["--threads", "1"]), &[]));
    assert_ok(&vibrobar_env(&args(s(&b), &["--threads", "2"]), &[]));
    assert_eq!(fs::read(&a).unwrap(), fs::read(&b).unwrap());
    // With a cavity section every position has its own FE model (and ω₁); the nodes printed
    // are the FE shapes' (mode 2's moves off the uniform bar's 137.10 mm).
    let sc = p(d.path(), "holed.toml");
    fs::write(
        &sc,
        "[beam]\ncavity_section = { hole_diameter_m = 0.018, length_m = 0.012 }\n",
    )
    .unwrap();
    let out = p(d.path(), "h.csv");
    let mut v: Vec<String> = args(s(&out), &[]).iter().map(|x| x.to_string()).collect();
    let i = v.iter().position(|x| x == "--positions-mm").unwrap();
    v[i + 1] = "115:165:25".into();
    v.extend(["--scenario".into(), s(&sc).into()]);
    let o = vibrobar_env(&v, &[]);
    assert_ok(&o);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("nodes of mode 2 of the damped bar: "),
        "{stdout}"
    );
    assert!(!stdout.contains("137.10 mm"), "{stdout}");
    assert_eq!(fs::read_to_string(&out).unwrap().lines().count(), 7);
}
