//! Regression tests of issue #7's persistence defects, end to end: special files as `--out`,
//! outputs that are inputs, optimum files of two maps in one folder, SIGINT during `run`, a full
//! disk, constant-memory `run`, and the map metadata's regime tolerances.
//!
//! Device nodes are never written here (CI runs as root): FIFOs and symlinks made in a temp dir
//! stand in for them; `/dev/null` is only checked through the policy's decision (io crate tests).

mod common;

use common::{assert_fails_with, bin, names, s, stderr, vibrobar};
use std::fs;
use std::os::unix::fs::FileTypeExt;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

fn mkfifo(p: &Path) {
    let st = Command::new("mkfifo").arg(p).status().expect("mkfifo runs");
    assert!(st.success());
}

/// A 3 × 2 map: `vibrobar` arguments with the friction law, duration and output given.
fn tiny_map<'a>(friction: &'a str, duration_s: &'a str, out: &'a str) -> [&'a str; 11] {
    [
        "map",
        "--friction",
        friction,
        "--ratios",
        "0.99:1.01:0.01",
        "--gaps-mm",
        "0.1:0.2:0.1",
        "--duration",
        duration_s,
        "--out",
        out,
    ]
}

const SHORT_RUN: [&str; 5] = ["run", "--preset", "paper", "--duration", "0.01"];

#[test]
fn regression_run_out_fifo_is_written_through_not_replaced() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe");
    mkfifo(&fifo);
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || fs::read(fifo).unwrap())
    };
    let mut args = SHORT_RUN.to_vec();
    args.extend(["--out", s(&fifo)]);
    let o = vibrobar(&args);
    if !o.status.success() {
        // Release the reader (blocked in open) before failing, so the test cannot hang.
        let _ = fs::OpenOptions::new().write(true).open(&fifo);
        panic!("{}", stderr(&o));
    }
    let summary = String::from_utf8_lossy(&o.stdout);
    assert!(
        summary.contains("(no .meta.json beside a special file)"),
        "{summary}"
    );
    let data = reader.join().unwrap();
    let text = String::from_utf8(data).unwrap();
    assert!(
        text.starts_with("t_s,u_m,du_m_s,v_m,dv_m_s,w_m,dw_m_s\n"),
        "{text}"
    );
    assert_eq!(text.lines().count(), 1 + 1001);
    assert!(fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());
    assert_eq!(
        names(dir.path()),
        vec!["pipe"],
        "no sidecar or partial files"
    );
}

#[test]
fn regression_run_out_symlink_writes_its_target_and_stays_a_link() {
    let dir = tempfile::tempdir().unwrap();
    fs::create_dir(dir.path().join("data")).unwrap();
    let target = dir.path().join("data/h.csv");
    fs::write(&target, "old\n").unwrap();
    let link = dir.path().join("h.csv");
    std::os::unix::fs::symlink("data/h.csv", &link).unwrap();
    let mut args = SHORT_RUN.to_vec();
    args.extend(["--out", s(&link)]);
    let o = vibrobar(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    let text = fs::read_to_string(&target).unwrap();
    assert!(text.starts_with("t_s,"), "{text}");
    assert!(!dir.path().join("data/h.csv.partial").exists());
    assert!(dir.path().join("h.csv.meta.json").exists());
}

#[test]
fn regression_map_out_fifo_is_refused_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe");
    mkfifo(&fifo);
    let o = vibrobar(&tiny_map("none", "0.01", s(&fifo)));
    assert_fails_with(&o, &["is a FIFO"]);
    assert!(fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());
    assert_eq!(names(dir.path()), vec!["pipe"]);
}

#[test]
fn regression_run_out_equal_to_its_scenario_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let sc = dir.path().join("s.toml");
    let text = "[run]\nduration_s = 0.01\n";
    fs::write(&sc, text).unwrap();
    let o = vibrobar(&["run", "--scenario", s(&sc), "--out", s(&sc)]);
    assert_fails_with(&o, &["is also an input"]);
    assert_eq!(fs::read_to_string(&sc).unwrap(), text);
}

fn small_map(out: &Path, friction: &str) -> Output {
    vibrobar(&tiny_map(friction, "0.02", s(out)))
}

#[test]
fn regression_two_maps_in_one_folder_keep_their_own_optimum() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.csv"), dir.path().join("b.csv"));
    for (out, friction) in [(&a, "none"), (&b, "as-published")] {
        let o = small_map(out, friction);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let oa = fs::read_to_string(dir.path().join("a.optimum.csv")).unwrap();
    let ob = fs::read_to_string(dir.path().join("b.optimum.csv")).unwrap();
    assert_ne!(oa, ob, "each map keeps its own optimum");
    assert!(!dir.path().join("optimum.csv").exists());
}

#[test]
fn regression_map_metadata_reloads_the_regime_tolerances() {
    use vibrobar_cli::commands::map::spec_from_params;
    use vibrobar_io::params::MapParams;
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.csv");
    let o = small_map(&out, "none");
    assert!(o.status.success(), "{}", stderr(&o));
    let mut meta = vibrobar_io::Metadata::read_beside(&out).unwrap();
    let p: MapParams = meta.parameters_as(&out).unwrap();
    let (spec, solver) = spec_from_params(&p).unwrap();
    assert_eq!(spec.tolerances, p.regime_tolerances);
    assert_eq!(solver, "exact");
    // Non-default tolerances written to the file are the ones reloaded (they were reloaded as
    // defaults before).
    meta.parameters["regime_tolerances"]["phase_tol"] = serde_json::json!(0.037);
    meta.parameters["regime_tolerances"]["k_max"] = serde_json::json!(5);
    let p: MapParams = meta.parameters_as(&out).unwrap();
    let (spec, _) = spec_from_params(&p).unwrap();
    assert_eq!(spec.tolerances.phase_tol, 0.037);
    assert_eq!(spec.tolerances.k_max, 5);
}

/// Run the binary with a file-size limit of 0 bytes: every write to a regular file fails, as on
/// a full disk (EFBIG instead of ENOSPC; SIGXFSZ ignored so the write returns the error).
fn full_disk(args: &[&str]) -> Output {
    let mut c = bin();
    c.args(args);
    // SAFETY: only async-signal-safe calls between fork and exec.
    unsafe {
        c.pre_exec(|| {
            libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
            let lim = libc::rlimit {
                rlim_cur: 0,
                rlim_max: libc::RLIM_INFINITY,
            };
            if libc::setrlimit(libc::RLIMIT_FSIZE, &lim) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    c.output().expect("binary runs")
}

#[test]
fn regression_npy_to_a_full_disk_names_the_file_and_leaves_no_partial() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.npy");
    let mut args = SHORT_RUN.to_vec();
    args.extend(["--out", s(&out)]);
    let o = full_disk(&args);
    assert_fails_with(&o, &["x.npy"]);
    assert_eq!(names(dir.path()), Vec::<String>::new(), "nothing left");
}

#[test]
fn regression_full_disk_leaves_no_journal_that_looks_like_progress() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.csv");
    let o = full_disk(&tiny_map("none", "0.01", s(&out)));
    assert_fails_with(&o, &["m.csv.journal"]);
    assert_eq!(names(dir.path()), Vec::<String>::new(), "no 0-byte journal");
}

/// Spawn and wait; return (status, stderr, peak RSS in KiB after exec). The peak is the child's
/// own `VmHWM`, polled until it exits (a forked child's rusage would count the test process).
fn run_measured(mut c: Command) -> (i32, String, i64) {
    let mut child = c
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let status_file = format!("/proc/{}/status", child.id());
    let mut stderr = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        std::io::Read::read_to_string(&mut stderr, &mut s).unwrap();
        s
    });
    let mut peak = 0i64;
    let status = loop {
        if let Some(st) = child.try_wait().unwrap() {
            break st;
        }
        if let Ok(text) = fs::read_to_string(&status_file) {
            if let Some(kib) = text
                .lines()
                .find_map(|l| l.strip_prefix("VmHWM:"))
                .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<i64>().ok())
            {
                peak = peak.max(kib);
            }
        }
        std::thread::sleep(std::time::Duration::from_millis(2));
    };
    (status.code().unwrap_or(-1), reader.join().unwrap(), peak)
}

#[test]
fn regression_run_streams_its_history_in_constant_memory() {
    // 4·10⁶ rows: holding them took 160 MB for the states alone (and as much again for the
    // flat NPY array); streamed, the process stays near its size without output (~14 MB).
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("h.npy");
    let mut c = bin();
    c.args([
        "run",
        "--preset",
        "paper",
        "--duration",
        "4",
        "--sample-every",
        "1",
        "--out",
        s(&out),
    ]);
    let (status, stderr, rss_kib) = run_measured(c);
    assert_eq!(status, 0, "{stderr}");
    let bytes = fs::metadata(&out).unwrap().len();
    assert_eq!(bytes, 128 + 8 * 7 * 4_000_001);
    assert!(rss_kib > 0 && rss_kib < 60_000, "peak RSS {rss_kib} KiB");
}

#[test]
fn regression_sigint_during_run_removes_the_partial_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let out: PathBuf = dir.path().join("long.csv");
    // 20 s of output (~200 MB) if the signal were ignored; stopped after the first 100 kB.
    let mut child = bin()
        .args([
            "run",
            "--preset",
            "paper",
            "--duration",
            "20",
            "--out",
            s(&out),
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let partial = dir.path().join("long.csv.partial");
    let t0 = std::time::Instant::now();
    while fs::metadata(&partial).map_or(0, |m| m.len()) < 100_000 {
        if t0.elapsed().as_secs() > 60 {
            let _ = child.kill();
            panic!("no partial output appeared");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    // SAFETY: signalling our own child.
    unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGINT) };
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(130));
    let e = stderr(&o);
    assert!(
        e.contains("interrupted: the run to") && e.contains("long.csv.partial"),
        "{e}"
    );
    assert_eq!(names(dir.path()), Vec::<String>::new(), "nothing left");
}

const MAP_ARGS: [&str; 9] = [
    "map",
    "--friction",
    "none",
    "--ratios",
    "0.99:1.01:0.01",
    "--gaps-mm",
    "0.1:0.2:0.1",
    "--duration",
    "0.02",
];

fn map_to(out: &Path, extra: &[&str]) -> Output {
    let mut args = MAP_ARGS.to_vec();
    args.extend(["--out", s(out)]);
    args.extend(extra);
    vibrobar(&args)
}

#[test]
fn regression_second_resume_on_a_held_journal_names_the_holder() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.csv");
    let journal = dir.path().join("m.csv.journal");
    // This test process holds the lock, as a first `--resume` still computing would.
    let held = vibrobar_io::lock::LockFile::acquire(&journal).unwrap();
    let o = map_to(&out, &["--resume"]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("in use by another vibrobar process")
            && e.contains(&format!("pid {}", std::process::id())),
        "{e}"
    );
    assert!(!out.exists() && !journal.exists());
    drop(held);
    let o = map_to(&out, &["--resume"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// A journal of the whole small map, made from a finished run's rows, with `edit` applied.
fn journal_from_finished_map(dir: &Path, edit: impl Fn(Vec<String>) -> Vec<String>) -> PathBuf {
    let full = dir.join("full/m.csv");
    let o = map_to(&full, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let meta = vibrobar_io::Metadata::read_beside(&full).unwrap();
    let text = fs::read_to_string(&full).unwrap();
    let rows: Vec<String> = text
        .lines()
        .skip(1)
        .enumerate()
        .map(|(i, r)| format!("{i},{r}"))
        .take(4)
        .collect();
    let out = dir.join("part/m.csv");
    fs::create_dir_all(out.parent().unwrap()).unwrap();
    let mut j = format!(
        "# vibrobar journal v1 fingerprint={}\nindex,{}\n",
        meta.fingerprint, meta.header
    );
    for r in edit(rows) {
        j.push_str(&r);
        j.push('\n');
    }
    fs::write(dir.join("part/m.csv.journal"), j).unwrap();
    out
}

#[test]
fn regression_map_journal_row_with_swapped_index_is_refused_with_its_line() {
    let dir = tempfile::tempdir().unwrap();
    // Untouched, the hand-made journal resumes to the same map (the check accepts real rows).
    let out = journal_from_finished_map(dir.path(), |r| r);
    let o = map_to(&out, &["--resume"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        fs::read(&out).unwrap(),
        fs::read(dir.path().join("full/m.csv")).unwrap()
    );
    let dir = tempfile::tempdir().unwrap();
    let out = journal_from_finished_map(dir.path(), |mut r| {
        // Row 2's text filed under index 1: the map would lose point 1 and double point 2.
        let row2 = r[2].split_once(',').unwrap().1.to_string();
        r[1] = format!("1,{row2}");
        r
    });
    let o = map_to(&out, &["--resume"]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("m.csv.journal: line 4") && e.contains("index 1 is the grid point 0.99,0.2"),
        "{e}"
    );
    assert!(!out.exists());
}

#[test]
fn regression_map_journal_row_with_nan_is_refused_with_its_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = journal_from_finished_map(dir.path(), |mut r| {
        let f: Vec<&str> = r[3].split(',').collect();
        let mut f: Vec<String> = f.iter().map(|x| x.to_string()).collect();
        f[4] = "NaN".into(); // rms_damped_m
        r[3] = f.join(",");
        r
    });
    let o = map_to(&out, &["--resume"]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("m.csv.journal: line 6")
            && e.contains("rms_damped_m = NaN is not a finite number"),
        "{e}"
    );
}

#[test]
fn run_and_sweep_metadata_reload_as_their_typed_parameters() {
    use vibrobar_io::params::{RunParams, SweepParams};
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("r.csv");
    let mut args = SHORT_RUN.to_vec();
    args.extend(["--out", s(&run)]);
    assert!(vibrobar(&args).status.success());
    let meta = vibrobar_io::Metadata::read_beside(&run).unwrap();
    let p: RunParams<serde_json::Value> = meta.parameters_as(&run).unwrap();
    assert_eq!(p.settings.duration_s, 0.01);
    assert_eq!(p.sample_interval_s, Some(1e-5));
    let sweep = dir.path().join("s.csv");
    let o = vibrobar(&[
        "sweep",
        "--preset",
        "paper",
        "--gap-mm",
        "0.1",
        "--ratios",
        "0.99:1.01:0.01",
        "--duration",
        "0.01",
        "--out",
        s(&sweep),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let meta = vibrobar_io::Metadata::read_beside(&sweep).unwrap();
    let p: SweepParams<serde_json::Value> = meta.parameters_as(&sweep).unwrap();
    assert_eq!(p.gaps_m, vec![1e-4]);
    assert_eq!(p.ratios.len(), 3);
    assert_eq!(p.order, "gap-major");
}

#[test]
fn regression_metadata_of_older_versions_still_loads() {
    // The committed design maps were written before the typed metadata (no `note` field).
    let docs = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/maps");
    for d in [
        "none_none",
        "coulomb_stated",
        "as-published_stated",
        "as-published_20N",
    ] {
        let map = docs.join(d).join("map.csv");
        let meta = vibrobar_io::Metadata::read_beside(&map).unwrap();
        let p: vibrobar_io::params::MapParams = meta.parameters_as(&map).unwrap();
        let (spec, _) = vibrobar_cli::commands::map::spec_from_params(&p).unwrap();
        assert_eq!(spec.settings.duration_s, 2.0, "{d}");
        assert_eq!(p.grid_values_si["freq_ratio"].len(), 41, "{d}");
    }
}

#[test]
fn regression_out_link_to_stdout_writes_through_the_pipe() {
    // As `--out /dev/stdout` (a link to /proc/self/fd/1), but through a link of our own, so that
    // a regression replaces the temp link, never /dev/stdout.
    let dir = tempfile::tempdir().unwrap();
    let link = dir.path().join("out.csv");
    std::os::unix::fs::symlink("/proc/self/fd/1", &link).unwrap();
    let mut args = SHORT_RUN.to_vec();
    args.extend(["--out", s(&link)]);
    let o = vibrobar(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.starts_with("t_s,u_m,du_m_s,v_m,dv_m_s,w_m,dw_m_s\n"),
        "{stdout}"
    );
    assert!(fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    assert_eq!(names(dir.path()), vec!["out.csv"]);
}

#[test]
fn streamed_npy_announces_exactly_the_rows_the_run_gives() {
    // The NPY header is written before the run from the output grid; a wrong count would be
    // refused at the end (RowCount). Odd steps, durations and intervals, both solvers.
    let dir = tempfile::tempdir().unwrap();
    for (solver, dt, duration, every) in [
        ("rk4", "3e-6", "0.0123", "7"),
        ("rk4", "1e-6", "0.01", "10"),
        ("exact", "1e-6", "0.0137", "13"),
        ("exact", "7e-7", "0.02", "1"),
    ] {
        let npy = dir.path().join("h.npy");
        let csv = dir.path().join("h.csv");
        for out in [&npy, &csv] {
            let o = vibrobar(&[
                "run",
                "--preset",
                "paper",
                "--solver",
                solver,
                "--dt",
                dt,
                "--duration",
                duration,
                "--sample-every",
                every,
                "--out",
                s(out),
            ]);
            assert!(
                o.status.success(),
                "{solver} {dt} {duration} {every}: {}",
                stderr(&o)
            );
        }
        let (shape, data) =
            vibrobar_io::npy::decode_f64(&fs::read(&npy).unwrap(), "h.npy").unwrap();
        let rows = fs::read_to_string(&csv).unwrap().lines().count() - 1;
        assert_eq!(shape, vec![rows, 7], "{solver} {dt} {duration} {every}");
        assert_eq!(data.len(), 7 * rows);
    }
}
