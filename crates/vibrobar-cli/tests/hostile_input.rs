//! Issue #7 A2, A4, A5, A6, A10: the hostile probes end quickly with a clear error naming the
//! flag or field and its range, never allocate without a limit, never hang, never panic on a
//! closed pipe. Every child runs with a wall-clock timeout and (on Unix) a 4 GiB address-space
//! limit, so a regression fails the test instead of eating the machine.

mod common;

use common::{bin, limit_memory, run_limited, wait_or_kill, Run};
use std::process::{ExitStatus, Stdio};
use std::time::{Duration, Instant};

const TIMEOUT: Duration = Duration::from_secs(20);

/// Run the binary in `dir` with a timeout; panics (after killing it) if it does not end.
fn run_in(dir: &std::path::Path, args: &[&str]) -> Run {
    run_limited(dir, args, TIMEOUT)
}

/// The probe must fail cleanly (status 1 or clap's 2), quickly, with every `want` in its stderr.
fn refused(dir: &std::path::Path, args: &[&str], want: &[&str]) {
    let r = run_in(dir, args);
    let code = r.status.code();
    assert!(
        code == Some(1) || code == Some(2),
        "vibrobar {args:?}: status {:?}\nstderr: {}",
        r.status,
        r.stderr
    );
    assert!(!r.stderr.contains("panicked"), "{args:?}: {}", r.stderr);
    for w in want {
        assert!(
            r.stderr.contains(w),
            "vibrobar {args:?}: stderr lacks {w:?}:\n{}",
            r.stderr
        );
    }
    // No 300-digit numbers.
    assert!(
        r.stderr.lines().all(|l| l.len() < 400),
        "{args:?}: {}",
        r.stderr
    );
    assert!(
        r.wall < Duration::from_secs(10),
        "{args:?} took {:?}",
        r.wall
    );
}

#[test]
fn regression_size_limits_refuse_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let map = |extra: &[&'static str]| -> Vec<&'static str> {
        let mut v = vec![
            "map",
            "--friction",
            "none",
            "--ratios",
            "1:1:1",
            "--gaps-mm",
            "0.1:0.1:0.1",
            "--out",
            "m.csv",
        ];
        v.extend_from_slice(extra);
        v
    };
    let probes: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (
            vec!["run", "--dt", "1e-320", "--out", "r.csv"],
            vec!["rows", "--sample-every", "[1, 1e7]"],
        ),
        (
            vec!["run", "--dt", "1e-12", "--out", "r.csv"],
            vec!["rows", "[1, 1e7]"],
        ),
        (
            vec!["run", "--duration", "1e308", "--out", "r.csv"],
            vec!["--duration", "[1, 1e7]"],
        ),
        (
            vec![
                "run",
                "--solver",
                "rk4",
                "--dt",
                "1e-320",
                "--sample-every",
                "1000000000",
                "--out",
                "r.csv",
            ],
            vec!["--dt"],
        ),
        (
            vec![
                "run",
                "--solver",
                "rk4",
                "--dt",
                "1e-9",
                "--duration",
                "10",
                "--sample-every",
                "100000",
                "--out",
                "r.csv",
            ],
            vec!["steps duration/dt", "[0, 1e9]"],
        ),
        (
            map(&["--duration", "1e308"]),
            vec!["--duration", "[0, 1e10]"],
        ),
        (
            vec![
                "map",
                "--friction",
                "none",
                "--ratios",
                "0.5:1.5:0.00001",
                "--gaps-mm",
                "0.01:1:0.00001",
                "--out",
                "m.csv",
            ],
            vec!["grid points", "[1, 1e7]"],
        ),
        (
            vec![
                "ensemble",
                "--friction",
                "none",
                "--ratio",
                "1",
                "--gap-mm",
                "0.1",
                "--members",
                "1000000000",
                "--out",
                "e.csv",
            ],
            vec!["--members", "1e9", "[1, 100000]"],
        ),
        (
            vec![
                "paper",
                "--quick",
                "--ensemble-members",
                "1000000000",
                "--out",
                "paper-out",
            ],
            vec!["--ensemble-members = 1e9", "[0, 100000]"],
        ),
        (
            vec![
                "bench-map",
                "--ratios",
                "4294967295",
                "--gaps",
                "4294967295",
            ],
            vec!["--ratios × --gaps", "[4, 1e7]"],
        ),
        (
            map(&["--shard", "1/99999999999"]),
            vec!["N of --shard K/N", "[1, 1e6]"],
        ),
        (
            vec![
                "poincare",
                "--friction",
                "none",
                "--ratio",
                "1",
                "--gap-mm",
                "0.1",
                "--duration",
                "1e6",
                "--dt",
                "1",
                "--out",
                "p.csv",
            ],
            vec!["Poincaré points", "[1, 1e7]"],
        ),
        (
            vec![
                "paper",
                "--quick",
                "--sample-interval-s",
                "1e-12",
                "--out",
                "paper-out",
            ],
            vec!["--sample-interval-s", "[1, 1e7]"],
        ),
        (
            map(&["--threads", "100000000"]),
            vec!["--threads = 1e8", "[1, 1024]"],
        ),
    ];
    for (args, want) in &probes {
        refused(d, args, want);
    }
    // Nothing was written by a refused run.
    for f in ["r.csv", "m.csv", "e.csv", "p.csv", "paper-out"] {
        assert!(!d.join(f).exists(), "{f} written");
    }
}

#[test]
fn regression_merge_refuses_a_huge_shard_count_from_metadata() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let r = run_in(
        d,
        &[
            "map",
            "--friction",
            "none",
            "--ratios",
            "1:1.01:0.01",
            "--gaps-mm",
            "0.1:0.1:0.1",
            "--duration",
            "0.01",
            "--shard",
            "1/2",
            "--out",
            "s1.csv",
        ],
    );
    assert!(r.status.success(), "{}", r.stderr);
    let meta_path = d.join("s1.csv.meta.json");
    let mut meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&meta_path).unwrap()).unwrap();
    meta["grid"]["shard"]["n"] = serde_json::json!(99_999_999_999u64);
    std::fs::write(&meta_path, serde_json::to_string(&meta).unwrap()).unwrap();
    refused(
        d,
        &["merge", "--out", "all.csv", "s1.csv"],
        &["s1.csv", "N of --shard K/N = 9.9999999999e10", "[1, 1e6]"],
    );
    assert!(!d.join("all.csv").exists());
}

#[test]
fn regression_nan_and_nonsense_inputs_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let probes: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (
            vec!["run", "--ratio", "1e151", "--out", "r.csv"],
            vec!["forcing.frequency_ratio = 1e151", "[0.001, 1000]"],
        ),
        (
            vec!["run", "--solver", "rk4", "--dt", "0.1", "--out", "r.csv"],
            vec!["--dt", "0.1", "stability"],
        ),
        (
            vec!["sweep", "--ratios=1e200:1e200:1", "--out", "s.csv"],
            vec!["forcing.frequency_ratio = 1e200", "[0.001, 1000]"],
        ),
        (
            vec![
                "map",
                "--friction",
                "none",
                "--ratios",
                "1:1:1",
                "--gaps-mm",
                "0.1:0.1:0.1",
                "--rms-fraction=1e-320",
                "--out",
                "m.csv",
            ],
            vec!["--rms-fraction", "1e-320", "at least one step"],
        ),
        (
            vec!["beam", "--diameter-mm", "1e308"],
            vec!["--diameter-mm", "1e305", "[1e-4, 10]"],
        ),
        (
            vec![
                "lyapunov",
                "--friction",
                "none",
                "--ratio",
                "1",
                "--gap-mm",
                "0.1",
                "--d0=1e-320",
            ],
            vec!["--d0", "1e-320", "[1e-12, 0.01]"],
        ),
    ];
    for (args, want) in &probes {
        refused(d, args, want);
    }
    for f in ["r.csv", "s.csv", "m.csv"] {
        assert!(!d.join(f).exists(), "{f} written");
    }
}

#[test]
fn regression_rk4_penetration_beyond_one_percent_of_the_gap_warns() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("push.toml"),
        "[forcing]\nstatic_force_n = 1e6\n[damper]\ngap_m = 1e-4\n",
    )
    .unwrap();
    let r = run_in(
        d,
        &[
            "run",
            "--scenario",
            "push.toml",
            "--solver",
            "rk4",
            "--duration",
            "0.01",
            "--out",
            "r.csv",
        ],
    );
    assert!(r.status.success(), "{}", r.stderr);
    assert!(
        r.stderr.contains("warning: the ball went 1.3")
            && r.stderr.contains("% of the gap (warning above 1 %)"),
        "{}",
        r.stderr
    );
    // The paper's own rk4 run (0.4 % of the gap at most) draws no warning.
    let r = run_in(
        d,
        &[
            "run",
            "--solver",
            "rk4",
            "--duration",
            "0.05",
            "--out",
            "p.csv",
        ],
    );
    assert!(r.status.success(), "{}", r.stderr);
    assert!(!r.stderr.contains("warning"), "{}", r.stderr);
}

#[test]
fn regression_negative_value_after_a_space_gets_the_range_error() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    refused(
        d,
        &["run", "--dt", "-1e-6", "--out", "r.csv"],
        &["--dt = -1e-6 s is outside the allowed range (0, ∞) s"],
    );
    refused(
        d,
        &["sweep", "--gap-mm", "-0.1,-1e-3", "--out", "s.csv"],
        &["--gap-mm = -0.1 mm is outside the allowed range"],
    );
    refused(
        d,
        &[
            "lyapunov",
            "--friction",
            "none",
            "--ratio",
            "1",
            "--gap-mm",
            "0.1",
            "--d0",
            "-1e-9",
        ],
        &["--d0 = -1e-9 is outside the allowed range"],
    );
    refused(
        d,
        &["run", "--sample-every", "-5", "--out", "r.csv"],
        &["invalid value '-5' for '--sample-every"],
    );
    // A forgotten value is still reported as such (the next flag is not swallowed).
    refused(
        d,
        &["run", "--gap-mm", "--out", "r.csv"],
        &["a value is required for '--gap-mm"],
    );
}

#[test]
fn regression_empty_toml_gaps_names_the_file_field() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.toml"), "[sweep]\ngaps_m = []\n").unwrap();
    let r = run_in(d, &["sweep", "--scenario", "s.toml", "--out", "s.csv"]);
    assert_eq!(r.status.code(), Some(1), "{}", r.stderr);
    assert!(r.stderr.contains("sweep.gaps_m = []"), "{}", r.stderr);
    assert!(!r.stderr.contains("error: --gap-mm"), "{}", r.stderr);
}

#[test]
fn regression_beam_cavity_flags_without_the_hole_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    for flag in ["--cavity-length-mm", "--cavity-distance-mm"] {
        refused(dir.path(), &["beam", flag, "3"], &["--cavity-hole-mm"]);
    }
    let r = run_in(
        dir.path(),
        &[
            "beam",
            "--cavity-hole-mm",
            "15.1",
            "--cavity-length-mm",
            "17",
            "--cavity-distance-mm",
            "38",
        ],
    );
    assert!(r.status.success(), "{}", r.stderr);
    assert!(r.stdout.contains("cavity 15.1 mm hole"), "{}", r.stdout);
}

/// Run with stdout and stderr on pipes whose read ends are already closed, so the first write
/// meets EPIPE deterministically.
#[cfg(unix)]
fn run_into_closed_pipes(dir: &std::path::Path, args: &[&str]) -> ExitStatus {
    use std::os::fd::{FromRawFd, OwnedFd};
    let closed_pipe = || -> Stdio {
        let mut fds = [0; 2];
        // SAFETY: plain pipe(2) and close(2) on the descriptors it returned.
        unsafe {
            assert_eq!(libc::pipe(fds.as_mut_ptr()), 0);
            libc::close(fds[0]);
            Stdio::from(OwnedFd::from_raw_fd(fds[1]))
        }
    };
    let mut cmd = bin();
    cmd.args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(closed_pipe())
        .stderr(closed_pipe());
    limit_memory(&mut cmd);
    let t0 = Instant::now();
    let mut child = cmd.spawn().expect("binary starts");
    wait_or_kill(&mut child, args, t0, TIMEOUT)
}

#[cfg(unix)]
#[test]
fn regression_broken_pipe_ends_quietly_by_sigpipe() {
    use std::os::unix::process::ExitStatusExt;
    let dir = tempfile::tempdir().unwrap();
    for args in [
        vec!["beam"],
        vec!["bench", "--duration", "0.001", "--single-only"],
        vec![
            "map",
            "--friction",
            "none",
            "--ratios",
            "1:1:1",
            "--gaps-mm",
            "0.1:0.1:0.1",
            "--duration",
            "0.01",
            "--out",
            "m.csv",
        ],
    ] {
        let s = run_into_closed_pipes(dir.path(), &args);
        // Status 101 was the panic "failed printing to stdout: Broken pipe".
        assert_eq!(
            s.signal(),
            Some(libc::SIGPIPE),
            "vibrobar {args:?} ended with {s:?}, not by SIGPIPE"
        );
    }
}

#[test]
fn regression_sweep_without_forcing_refuses_a_nan_reduction() {
    // A bar with no force at rest has RMS 0: the reduction was written as NaN with exit 0.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("z.toml"), "[forcing]\namplitude_n = 0\n").unwrap();
    refused(
        d,
        &[
            "sweep",
            "--scenario",
            "z.toml",
            "--ratios",
            "1:1:1",
            "--gap-mm",
            "0.1",
            "--duration",
            "0.01",
            "--out",
            "z.csv",
        ],
        &["reduction_pct", "rms_solid = 0", "forcing.amplitude_n"],
    );
    assert!(!d.join("z.csv").exists());
}
