//! Regression tests of issue #7's persistence defects, end to end: special files as `--out`,
//! outputs that are inputs, optimum files of two maps in one folder, SIGINT during `run`, a full
//! disk, constant-memory `run`, and the map metadata's regime tolerances.
//!
//! Device nodes are never written here (CI runs as root): FIFOs and symlinks made in a temp dir
//! stand in for them; `/dev/null` is only checked through the policy's decision (io crate tests).

use std::fs;
use std::os::unix::fs::FileTypeExt;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_vibrobar"))
}

fn vibrobar(args: &[&str]) -> Output {
    bin().args(args).output().expect("binary runs")
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn err(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn mkfifo(p: &Path) {
    let st = Command::new("mkfifo").arg(p).status().expect("mkfifo runs");
    assert!(st.success());
}

fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
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
    assert!(o.status.success(), "{}", err(&o));
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
    assert!(o.status.success(), "{}", err(&o));
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
    let o = vibrobar(&[
        "map",
        "--friction",
        "none",
        "--ratios",
        "0.99:1.01:0.01",
        "--gaps-mm",
        "0.1:0.2:0.1",
        "--duration",
        "0.01",
        "--out",
        s(&fifo),
    ]);
    assert!(!o.status.success());
    assert!(err(&o).contains("is a FIFO"), "{}", err(&o));
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
    assert!(!o.status.success());
    assert!(err(&o).contains("is also an input"), "{}", err(&o));
    assert_eq!(fs::read_to_string(&sc).unwrap(), text);
}

fn small_map(out: &Path, friction: &str) -> Output {
    vibrobar(&[
        "map",
        "--friction",
        friction,
        "--ratios",
        "0.99:1.01:0.01",
        "--gaps-mm",
        "0.1:0.2:0.1",
        "--duration",
        "0.02",
        "--out",
        s(out),
    ])
}

#[test]
fn regression_two_maps_in_one_folder_keep_their_own_optimum() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.csv"), dir.path().join("b.csv"));
    for (out, friction) in [(&a, "none"), (&b, "as-published")] {
        let o = small_map(out, friction);
        assert!(o.status.success(), "{}", err(&o));
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
    assert!(o.status.success(), "{}", err(&o));
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
    assert!(!o.status.success());
    assert!(err(&o).contains("x.npy"), "{}", err(&o));
    assert_eq!(names(dir.path()), Vec::<String>::new(), "nothing left");
}

#[test]
fn regression_full_disk_leaves_no_journal_that_looks_like_progress() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.csv");
    let o = full_disk(&[
        "map",
        "--friction",
        "none",
        "--ratios",
        "0.99:1.01:0.01",
        "--gaps-mm",
        "0.1:0.2:0.1",
        "--duration",
        "0.01",
        "--out",
        s(&out),
    ]);
    assert!(!o.status.success());
    assert!(err(&o).contains("m.csv.journal"), "{}", err(&o));
    assert_eq!(names(dir.path()), Vec::<String>::new(), "no 0-byte journal");
}

/// Spawn, wait, and return (status, stderr, peak RSS in KiB) of this one child.
#[allow(clippy::zombie_processes)] // reaped by wait4, which also gives its own rusage
fn run_measured(mut c: Command) -> (i32, String, i64) {
    let child = c
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let pid = child.id() as libc::pid_t;
    let mut stderr = child.stderr.unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        std::io::Read::read_to_string(&mut stderr, &mut s).unwrap();
        s
    });
    let mut status = 0;
    // SAFETY: plain wait4 on our own child; rusage is a plain struct.
    let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
    let r = unsafe { libc::wait4(pid, &mut status, 0, &mut ru) };
    assert_eq!(r, pid);
    (status, reader.join().unwrap(), ru.ru_maxrss)
}

#[test]
fn regression_run_streams_its_history_in_constant_memory() {
    // 2·10⁶ rows: holding them (State + the flat NPY array) took ≥ 190 MB; streamed, the
    // process stays near its size without output.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("h.npy");
    let mut c = bin();
    c.args([
        "run",
        "--preset",
        "paper",
        "--duration",
        "2",
        "--sample-every",
        "1",
        "--out",
        s(&out),
    ]);
    let (status, stderr, rss_kib) = run_measured(c);
    assert_eq!(status, 0, "{stderr}");
    let bytes = fs::metadata(&out).unwrap().len();
    assert_eq!(bytes, 128 + 8 * 7 * 2_000_001);
    assert!(rss_kib < 60_000, "peak RSS {rss_kib} KiB");
}

#[test]
fn regression_sigint_during_run_removes_the_partial_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let out: PathBuf = dir.path().join("long.csv");
    let child = bin()
        .args([
            "run",
            "--preset",
            "paper",
            "--duration",
            "200",
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
        assert!(t0.elapsed().as_secs() < 60, "no partial output appeared");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    // SAFETY: signalling our own child.
    unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGINT) };
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(130));
    let e = err(&o);
    assert!(
        e.contains("interrupted: the run to") && e.contains("long.csv.partial"),
        "{e}"
    );
    assert_eq!(names(dir.path()), Vec::<String>::new(), "nothing left");
}
