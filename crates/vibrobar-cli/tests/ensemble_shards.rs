//! `ensemble --shard K/N`, `--resume` and `merge` of its shards through the `vibrobar` binary
//! (issue #15): the same machinery as `map`, byte-identical to the unsharded run.

mod common;

use common::{assert_fails_with, assert_ok, s, vibrobar_env};
use std::fs;
use std::path::{Path, PathBuf};

const HEADER: &str = "ratio,gap_mm,members,mean_rms_m,std_rms_m,min_rms_m,max_rms_m,regimes";

/// 3 ratios × 2 gaps, 3 members each, 0.5 s exact runs.
fn args<'a>(out: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut v = vec![
        "ensemble",
        "--friction",
        "none",
        "--ratios",
        "0.95:1.05:0.05",
        "--gaps-mm",
        "0.5:1.0:0.5",
        "--members",
        "3",
        "--duration",
        "0.5",
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

fn meta(path: &Path) -> serde_json::Value {
    serde_json::from_str(&fs::read_to_string(format!("{}.meta.json", s(path))).unwrap()).unwrap()
}

#[test]
fn three_shards_merged_equal_the_unsharded_ensemble_byte_for_byte() {
    let d = tempfile::tempdir().unwrap();
    let full = p(d.path(), "full/e.csv");
    assert_ok(&vibrobar_env(&args(s(&full), &[]), &[]));
    let text = fs::read_to_string(&full).unwrap();
    assert_eq!(text.lines().next(), Some(HEADER));
    assert_eq!(text.lines().count(), 7);
    assert_eq!(meta(&full)["grid"]["total"], 6);
    let mut shards = Vec::new();
    for k in 1..=3 {
        let f = p(d.path(), &format!("shards/e.{k}.csv"));
        let spec = format!("{k}/3");
        assert_ok(&vibrobar_env(&args(s(&f), &["--shard", &spec]), &[]));
        // Round-robin: shard k holds grid indices k-1 and k+2.
        let rows = fs::read_to_string(&f).unwrap();
        assert_eq!(rows.lines().count(), 3, "{rows}");
        assert_eq!(meta(&f)["grid"]["shard"]["k"], k);
        shards.push(f);
    }
    assert_eq!(meta(&shards[0])["fingerprint"], meta(&full)["fingerprint"]);
    let merged = p(d.path(), "merged/e.csv");
    assert_ok(&vibrobar_env(
        &[
            "merge",
            "--out",
            s(&merged),
            s(&shards[2]),
            s(&shards[0]),
            s(&shards[1]),
        ],
        &[],
    ));
    assert_eq!(fs::read(&merged).unwrap(), fs::read(&full).unwrap());
    // A missing shard and a shard of another job are refused, and no merged file appears.
    let x = p(d.path(), "x.csv");
    let o = vibrobar_env(
        &["merge", "--out", s(&x), s(&shards[0]), s(&shards[2])],
        &[],
    );
    assert_fails_with(&o, &["missing shards [2]"]);
    assert!(!x.exists());
    let other = p(d.path(), "other/e.2.csv");
    assert_ok(&vibrobar_env(
        &args(s(&other), &["--shard", "2/3", "--seed", "7"]),
        &[],
    ));
    let o = vibrobar_env(
        &[
            "merge",
            "--out",
            s(&x),
            s(&shards[0]),
            s(&other),
            s(&shards[2]),
        ],
        &[],
    );
    assert_fails_with(&o, &["comes from another job"]);
    assert!(!x.exists());
}

#[test]
fn ensemble_resume_after_an_interruption_is_byte_identical() {
    let d = tempfile::tempdir().unwrap();
    let full = p(d.path(), "full/e.csv");
    assert_ok(&vibrobar_env(&args(s(&full), &[]), &[]));
    let fingerprint = meta(&full)["fingerprint"].as_str().unwrap().to_string();
    let rows: Vec<String> = fs::read_to_string(&full)
        .unwrap()
        .lines()
        .skip(1)
        .map(str::to_string)
        .collect();
    // A journal as a killed run leaves it: some rows, a torn last line.
    let out = p(d.path(), "part/e.csv");
    fs::create_dir_all(out.parent().unwrap()).unwrap();
    let mut j = format!("# vibrobar journal v1 fingerprint={fingerprint}\nindex,{HEADER}\n");
    for i in [0usize, 3] {
        j.push_str(&format!("{i},{}\n", rows[i]));
    }
    j.push_str(&format!("1,{}", &rows[1][..rows[1].len() / 2]));
    fs::write(journal_of(&out), &j).unwrap();
    let o = vibrobar_env(&args(s(&out), &[]), &[]);
    assert_fails_with(&o, &["--resume"]);
    assert!(!out.exists());
    // A journal row whose key does not match its index is refused with its line.
    let bad = p(d.path(), "bad/e.csv");
    fs::create_dir_all(bad.parent().unwrap()).unwrap();
    fs::write(
        journal_of(&bad),
        format!(
            "# vibrobar journal v1 fingerprint={fingerprint}\nindex,{HEADER}\n2,{}\n",
            rows[0]
        ),
    )
    .unwrap();
    let o = vibrobar_env(&args(s(&bad), &["--resume"]), &[]);
    assert_fails_with(&o, &["line 3"]);
    assert!(!bad.exists());
    assert_ok(&vibrobar_env(&args(s(&out), &["--resume"]), &[]));
    assert_eq!(fs::read(&out).unwrap(), fs::read(&full).unwrap());
    assert!(!journal_of(&out).exists());
}

#[test]
fn ensemble_shard_out_of_range_is_refused_before_any_file() {
    let d = tempfile::tempdir().unwrap();
    let out = p(d.path(), "e.csv");
    for bad in ["0/3", "4/3", "1/0", "x"] {
        let o = vibrobar_env(&args(s(&out), &["--shard", bad]), &[]);
        assert_fails_with(&o, &["shard"]);
        assert!(!out.exists());
        assert!(!journal_of(&out).exists());
    }
}
