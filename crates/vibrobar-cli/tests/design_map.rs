//! End-to-end tests of `map` and `merge` through the `vibrobar` binary, on tiny grids
//! with short runs.

mod common;

use common::{assert_fails_with, assert_ok, bin, s, vibrobar_env};
use std::fs;
use std::path::{Path, PathBuf};

const HEADER: &str = "ratio,gap_mm,rms_solid_m,rms_damped_m,reduction_pct,impacts_per_cycle,regime";

/// A tiny map around resonance: 5 ratios × 3 gaps, 0.05 s runs with rk4.
fn map_args<'a>(out: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut v = vec![
        "map",
        "--preset",
        "paper",
        "--friction",
        "none",
        "--ratios",
        "0.98:1.02:0.01",
        "--gaps-mm",
        "0.1:0.3:0.1",
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

fn p(dir: &Path, name: &str) -> PathBuf {
    dir.join(name)
}

fn read_rows(path: &Path) -> Vec<Vec<String>> {
    fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

#[test]
fn map_writes_the_contract_header_metadata_optimum_and_figures() {
    let d = tempfile::tempdir().unwrap();
    let out = p(d.path(), "m.csv");
    assert_ok(&vibrobar_env(&map_args(s(&out), &[]), &[]));
    let text = fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some(HEADER));
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), 15);
    // Row-major: ratio outer, gap inner, printed without rounding noise.
    assert!(rows[0].starts_with("0.98,0.1,"), "{}", rows[0]);
    assert!(rows[4].starts_with("0.99,0.2,"), "{}", rows[4]);
    assert!(rows[14].starts_with("1.02,0.3,"), "{}", rows[14]);
    let meta: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(p(d.path(), "m.csv.meta.json")).unwrap()).unwrap();
    assert_eq!(meta["kind"], "map");
    assert_eq!(meta["header"], HEADER);
    assert_eq!(meta["grid"]["total"], 15);
    assert!(meta["grid"]["shard"].is_null());
    assert_eq!(meta["parameters"]["solver"], "rk4");
    assert_eq!(meta["parameters"]["settings"]["duration_s"], 0.05);
    assert_eq!(meta["parameters"]["friction"], "none");
    assert!(meta["fingerprint"].as_str().unwrap().len() == 16);
    for f in [
        "m.optimum.csv",
        "m.reduction.png",
        "m.reduction.svg",
        "m.impacts.png",
        "m.impacts.svg",
    ] {
        let len = fs::metadata(p(d.path(), f)).map(|m| m.len()).unwrap_or(0);
        assert!(len > 1000 || f == "m.optimum.csv", "{f}: {len} bytes");
    }
    assert!(!p(d.path(), "m.csv.journal").exists());
}

#[test]
fn optimum_csv_agrees_with_the_map() {
    let d = tempfile::tempdir().unwrap();
    let out = p(d.path(), "m.csv");
    assert_ok(&vibrobar_env(&map_args(s(&out), &[]), &[]));
    let rows = read_rows(&out);
    let opt = fs::read_to_string(p(d.path(), "m.optimum.csv")).unwrap();
    let mut lines = opt.lines();
    assert_eq!(
        lines.next(),
        Some("ratio,best_gap_mm,best_reduction_pct,rms_damped_m,rms_solid_m,impacts_per_cycle,regime,criterion,friction_work_j,work_input_j")
    );
    let opt: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    let red = |r: &Vec<String>| r[4].parse::<f64>().unwrap();
    // Per ratio: the largest reduction, first gap on ties.
    let ratios = ["0.98", "0.99", "1", "1.01", "1.02"];
    for (k, ratio) in ratios.iter().enumerate() {
        let best = rows
            .iter()
            .filter(|r| r[0] == *ratio)
            .fold(None::<&Vec<String>>, |b, r| match b {
                Some(b) if red(b) >= red(r) => Some(b),
                _ => Some(r),
            })
            .unwrap();
        let o = &opt[k];
        assert_eq!(o[0], *ratio);
        assert_eq!(o[1], best[1], "best gap at {ratio}");
        assert_eq!(o[2], best[4]);
        assert_eq!(o[3], best[3]);
        assert_eq!(o[4], best[2]);
        assert_eq!(o[6], best[6]);
        assert_eq!(o[7], "max-reduction");
        // Frictionless: no friction work; the cutting force does positive work from rest.
        assert_eq!(o[8].parse::<f64>().unwrap(), 0.0);
        assert!(o[9].parse::<f64>().unwrap() > 0.0, "work input {}", o[9]);
    }
    // Band: mean reduction and minimax RMS per gap, computed here independently.
    let gaps = ["0.1", "0.2", "0.3"];
    let mean = |g: &str| {
        let v: Vec<f64> = rows.iter().filter(|r| r[1] == g).map(red).collect();
        v.iter().sum::<f64>() / v.len() as f64
    };
    let worst = |g: &str| {
        rows.iter()
            .filter(|r| r[1] == g)
            .map(|r| r[3].parse::<f64>().unwrap())
            .fold(f64::NEG_INFINITY, f64::max)
    };
    let best_mean = gaps
        .iter()
        .copied()
        .fold(None::<&str>, |b, g| match b {
            Some(b) if mean(b) >= mean(g) => Some(b),
            _ => Some(g),
        })
        .unwrap();
    let best_minimax = gaps
        .iter()
        .copied()
        .fold(None::<&str>, |b, g| match b {
            Some(b) if worst(b) <= worst(g) => Some(b),
            _ => Some(g),
        })
        .unwrap();
    let band: Vec<&Vec<&str>> = opt.iter().filter(|o| o[0] == "band").collect();
    assert_eq!(band.len(), 2);
    assert!(band
        .iter()
        .all(|b| b.len() == 10 && b[8].is_empty() && b[9].is_empty()));
    assert_eq!(band[0][7], "band-mean-reduction");
    assert_eq!(band[0][1], best_mean);
    assert!((band[0][2].parse::<f64>().unwrap() - mean(best_mean)).abs() < 1e-9);
    assert_eq!(band[1][7], "band-minimax-rms");
    assert_eq!(band[1][1], best_minimax);
    assert_eq!(band[1][3].parse::<f64>().unwrap(), worst(best_minimax));
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let d = tempfile::tempdir().unwrap();
    let a = p(d.path(), "a/m.csv");
    let b = p(d.path(), "b/m.csv");
    assert_ok(&vibrobar_env(
        &map_args(s(&a), &[]),
        &[("RAYON_NUM_THREADS", "1")],
    ));
    assert_ok(&vibrobar_env(
        &map_args(s(&b), &[]),
        &[("RAYON_NUM_THREADS", "2")],
    ));
    assert_eq!(fs::read(&a).unwrap(), fs::read(&b).unwrap());
    assert_eq!(
        fs::read(p(d.path(), "a/m.optimum.csv")).unwrap(),
        fs::read(p(d.path(), "b/m.optimum.csv")).unwrap()
    );
    let c = p(d.path(), "c/m.csv");
    assert_ok(&vibrobar_env(&map_args(s(&c), &["--threads", "2"]), &[]));
    assert_eq!(fs::read(&a).unwrap(), fs::read(&c).unwrap());
}

#[test]
fn shards_merged_equal_the_unsharded_map_byte_for_byte() {
    let d = tempfile::tempdir().unwrap();
    let full = p(d.path(), "full/m.csv");
    assert_ok(&vibrobar_env(&map_args(s(&full), &[]), &[]));
    let mut shards = Vec::new();
    for k in 1..=3 {
        let f = p(d.path(), &format!("shards/m.{k}.csv"));
        let spec = format!("{k}/3");
        assert_ok(&vibrobar_env(&map_args(s(&f), &["--shard", &spec]), &[]));
        let meta: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(format!("{}.meta.json", s(&f))).unwrap())
                .unwrap();
        assert_eq!(meta["grid"]["shard"]["k"], k);
        shards.push(f);
    }
    // Shards write only data and metadata.
    assert!(!p(d.path(), "shards/m.optimum.csv").exists());
    assert!(!p(d.path(), "shards/m.1.optimum.csv").exists());
    assert!(!p(d.path(), "shards/m.1.reduction.png").exists());
    // Same fingerprint as the unsharded job: the shard is not a parameter.
    let fp = |f: &Path| {
        let m: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(format!("{}.meta.json", s(f))).unwrap())
                .unwrap();
        m["fingerprint"].as_str().unwrap().to_string()
    };
    assert_eq!(fp(&shards[0]), fp(&full));
    let merged = p(d.path(), "merged/m.csv");
    let mut args = vec!["merge", "--out", s(&merged)];
    // Any order.
    args.extend([s(&shards[2]), s(&shards[0]), s(&shards[1])]);
    assert_ok(&vibrobar_env(&args, &[]));
    assert_eq!(fs::read(&merged).unwrap(), fs::read(&full).unwrap());
    assert_eq!(
        fs::read(p(d.path(), "merged/m.optimum.csv")).unwrap(),
        fs::read(p(d.path(), "full/m.optimum.csv")).unwrap()
    );
    assert!(p(d.path(), "merged/m.reduction.png").exists());
    // A missing shard is refused.
    let o = vibrobar_env(
        &[
            "merge",
            "--out",
            s(&p(d.path(), "x.csv")),
            s(&shards[0]),
            s(&shards[1]),
        ],
        &[],
    );
    assert_fails_with(&o, &["missing shards [3]"]);
}

fn journal_of(out: &Path) -> PathBuf {
    PathBuf::from(format!("{}.journal", s(out)))
}

#[test]
fn resume_from_a_torn_journal_is_byte_identical() {
    let d = tempfile::tempdir().unwrap();
    let full = p(d.path(), "full/m.csv");
    assert_ok(&vibrobar_env(&map_args(s(&full), &[]), &[]));
    let fingerprint = {
        let m: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(p(d.path(), "full/m.csv.meta.json")).unwrap())
                .unwrap();
        m["fingerprint"].as_str().unwrap().to_string()
    };
    let rows: Vec<String> = fs::read_to_string(&full)
        .unwrap()
        .lines()
        .skip(1)
        .map(str::to_string)
        .collect();
    // A journal as a killed run leaves it: some rows in completion order, a torn last line.
    let out = p(d.path(), "part/m.csv");
    fs::create_dir_all(out.parent().unwrap()).unwrap();
    let mut j = format!("# vibrobar journal v1 fingerprint={fingerprint}\nindex,{HEADER}\n");
    for i in [7usize, 2, 11, 0, 5] {
        j.push_str(&format!("{i},{}\n", rows[i]));
    }
    j.push_str(&format!("9,{}", &rows[9][..rows[9].len() / 2]));
    fs::write(journal_of(&out), j).unwrap();
    // Without --resume: refused, nothing overwritten.
    let o = vibrobar_env(&map_args(s(&out), &[]), &[]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("--resume"), "{err}");
    assert!(!out.exists());
    assert_ok(&vibrobar_env(&map_args(s(&out), &["--resume"]), &[]));
    assert_eq!(fs::read(&out).unwrap(), fs::read(&full).unwrap());
    assert!(!journal_of(&out).exists());
    // A journal of other parameters is refused.
    let other = p(d.path(), "other/m.csv");
    fs::create_dir_all(other.parent().unwrap()).unwrap();
    fs::write(
        journal_of(&other),
        format!("# vibrobar journal v1 fingerprint=0123456789abcdef\nindex,{HEADER}\n"),
    )
    .unwrap();
    let o = vibrobar_env(&map_args(s(&other), &["--resume"]), &[]);
    assert_fails_with(&o, &["different parameters"]);
}

#[test]
fn resume_after_sigkill_is_byte_identical() {
    let d = tempfile::tempdir().unwrap();
    // 40 points of 0.1 s runs; the killed run uses one thread, the reference and the resume
    // all cores (the thread count is not part of the job, so resuming with another is fine).
    let args = |out: &str, threads: Option<&str>| -> Vec<String> {
        let mut v: Vec<String> = [
            "map",
            "--friction",
            "none",
            "--ratios",
            "0.97:1.04:0.01",
            "--gaps-mm",
            "0.1:0.5:0.1",
            "--solver",
            "rk4",
            "--duration",
            "0.1",
            "--out",
            out,
        ]
        .iter()
        .map(|x| x.to_string())
        .collect();
        if let Some(t) = threads {
            v.extend(["--threads".to_string(), t.to_string()]);
        }
        v
    };
    let full = p(d.path(), "full/m.csv");
    let o = bin().args(args(s(&full), None)).output().unwrap();
    assert_ok(&o);
    let out = p(d.path(), "killed/m.csv");
    let mut child = bin()
        .args(args(s(&out), Some("1")))
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
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
        eprintln!("the run finished before it could be killed; only the resume path is tested");
    } else {
        let rows = fs::read_to_string(&jp).unwrap().lines().count() - 2;
        assert!((3..40).contains(&rows), "{rows} rows in the journal");
        let mut a = args(s(&out), None);
        a.push("--resume".into());
        assert_ok(&bin().args(a).output().unwrap());
    }
    assert_eq!(fs::read(&out).unwrap(), fs::read(&full).unwrap());
    assert!(!jp.exists());
}

#[test]
fn bad_input_is_a_clear_error_not_a_panic() {
    let d = tempfile::tempdir().unwrap();
    let out = p(d.path(), "m.csv");
    let o = s(&out);
    let base = |ratios: &str, gaps: &str| -> Vec<String> {
        [
            "map",
            "--friction",
            "none",
            "--ratios",
            ratios,
            gaps,
            "--solver",
            "rk4",
            "--duration",
            "0.05",
            "--out",
            o,
        ]
        .iter()
        .map(|x| x.to_string())
        .collect()
    };
    let cases: Vec<(Vec<String>, Vec<&str>)> = vec![
        (
            base("1.05:0.95:0.01", "--gaps-mm=0.1:0.2:0.1"),
            vec!["--ratios", "START ≤ STOP"],
        ),
        (
            base("0.95:1.05:0", "--gaps-mm=0.1:0.2:0.1"),
            vec!["--ratios", "STEP > 0"],
        ),
        (
            base("0.95:1.05:0.01", "--gaps-mm=-0.1:0.2:0.1"),
            vec!["--gaps-mm", "(0, ∞) mm"],
        ),
        (
            base("0.95:1.05:0.01", "--gaps-mm=0.1-0.2"),
            vec!["--gaps-mm", "START:STOP:STEP"],
        ),
        (
            {
                let mut v = base("0.95:1.05:0.01", "--gaps-mm=0.1:0.2:0.1");
                v.extend(["--shard".into(), "0/3".into()]);
                v
            },
            vec!["--shard", "1 ≤ K ≤ N"],
        ),
        (
            {
                let mut v = base("0.95:1.05:0.01", "--gaps-mm=0.1:0.2:0.1");
                v.extend(["--restitutions".into(), "0.5:1.5:0.5".into()]);
                v
            },
            vec!["--restitutions", "[0, 1]"],
        ),
        (
            {
                let mut v = base("0.95:1.05:0.01", "--gaps-mm=0.1:0.2:0.1");
                v[9] = "0".into();
                v
            },
            vec!["--duration", "(0, ∞)"],
        ),
        (
            {
                let mut v = base("0.95:1.05:0.01", "--gaps-mm=0.1:0.2:0.1");
                v[7] = "euler".into();
                v
            },
            vec!["--solver", "rk4"],
        ),
    ];
    // Negative numbers as separate tokens reach our checks (not clap's "unexpected argument").
    let sep = |v: &[&str]| -> Vec<String> { v.iter().map(|x| x.to_string()).collect() };
    let mut cases = cases;
    cases.push((
        sep(&[
            "map",
            "--friction",
            "none",
            "--ratios",
            "0.9:1:0.1",
            "--gaps-mm",
            "-0.1:0.2:0.1",
            "--out",
            o,
        ]),
        vec!["--gaps-mm", "(0, ∞) mm"],
    ));
    cases.push((
        sep(&[
            "poincare",
            "--friction",
            "none",
            "--ratio",
            "1",
            "--gap-mm",
            "-1",
            "--out",
            o,
        ]),
        vec!["--gap-mm", "(0, ∞) mm"],
    ));
    cases.push((
        sep(&[
            "map",
            "--friction",
            "none",
            "--ratios",
            "0.9:1:0.1",
            "--gaps-mm",
            "0.1:0.2:0.1",
            "--friction-force-n",
            "-2",
            "--out",
            o,
        ]),
        vec!["--friction-force-n", "[0, ∞) N"],
    ));
    for (args, want) in cases {
        let r = bin().args(&args).output().unwrap();
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(!r.status.success(), "{args:?} accepted");
        assert_ne!(r.status.code(), Some(101), "{args:?} panicked: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        for w in want {
            assert!(err.contains(w), "{args:?}: {err:?} lacks {w:?}");
        }
        assert!(!out.exists());
    }
}

#[test]
fn optional_axes_add_columns_after_gap() {
    let d = tempfile::tempdir().unwrap();
    let out = p(d.path(), "m.csv");
    assert_ok(&vibrobar_env(
        &[
            "map",
            "--friction",
            "coulomb",
            "--ratios",
            "0.99:1.01:0.01",
            "--gaps-mm",
            "0.1:0.2:0.1",
            "--friction-forces-n",
            "0:1:1",
            "--restitutions",
            "0.5:0.8:0.3",
            "--solver",
            "rk4",
            "--duration",
            "0.05",
            "--out",
            s(&out),
        ],
        &[],
    ));
    let text = fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("ratio,gap_mm,friction_force_n,restitution,rms_solid_m,rms_damped_m,reduction_pct,impacts_per_cycle,regime")
    );
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), 3 * 2 * 2 * 2);
    assert!(rows[0].starts_with("0.99,0.1,0,0.5,"), "{}", rows[0]);
    assert!(rows[1].starts_with("0.99,0.1,0,0.8,"), "{}", rows[1]);
    assert!(rows[2].starts_with("0.99,0.1,1,0.5,"), "{}", rows[2]);
    let opt = fs::read_to_string(p(d.path(), "m.optimum.csv")).unwrap();
    assert!(opt.lines().next().unwrap().ends_with(
        ",criterion,best_friction_force_n,best_restitution,friction_work_j,work_input_j"
    ));
}

#[test]
fn optimum_friction_work_sign_follows_the_friction_law() {
    // As published, F_ball·ẇ = f|ẇ| ≥ 0: friction puts energy in; Coulomb takes it out; none is 0.
    let d = tempfile::tempdir().unwrap();
    for (friction, want) in [
        ("as-published", "friction put energy in"),
        ("coulomb", "friction took energy out"),
        ("none", "(none)"),
    ] {
        let out = p(d.path(), &format!("{friction}/m.csv"));
        let o = vibrobar_env(
            &[
                "map",
                "--friction",
                friction,
                "--ratios",
                "0.99:1.01:0.01",
                "--gaps-mm",
                "0.1:0.2:0.1",
                "--duration",
                "0.05",
                "--out",
                s(&out),
            ],
            &[],
        );
        assert_ok(&o);
        let stdout = String::from_utf8_lossy(&o.stdout);
        let line = stdout
            .lines()
            .find(|l| l.starts_with("friction work at the 3 optimum points"))
            .unwrap_or_else(|| panic!("{friction}: no summary line in\n{stdout}"));
        assert!(line.contains(want), "{friction}: {line}");
        assert!(line.contains("cutting-force work"), "{line}");
        let opt = fs::read_to_string(out.with_file_name("m.optimum.csv")).unwrap();
        let per_ratio: Vec<Vec<&str>> = opt
            .lines()
            .skip(1)
            .map(|l| l.split(',').collect::<Vec<_>>())
            .filter(|f| f[7] == "max-reduction")
            .collect();
        assert_eq!(per_ratio.len(), 3);
        for f in per_ratio {
            let w: f64 = f[8].parse().unwrap();
            let input: f64 = f[9].parse().unwrap();
            match friction {
                "as-published" => assert!(w > 0.0, "{friction}: {w}"),
                "coulomb" => assert!(w < 0.0, "{friction}: {w}"),
                _ => assert_eq!(w, 0.0, "{friction}"),
            }
            assert!(input > 0.0 && w.abs() < input, "{friction}: {w} of {input}");
        }
    }
}
