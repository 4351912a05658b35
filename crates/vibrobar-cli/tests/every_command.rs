//! Issue #7, round 2: what must hold for every command, not only for `run` and `sweep`: an output
//! that is an input is refused (A1), Ctrl-C leaves no partial file and keeps journals resumable
//! (A9), and refusals come before any journal exists.

mod common;

use common::{assert_fails_with, bin, names, stderr, vibrobar_in};
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Output, Stdio};

const SCENARIO: &str = "[run]\nduration_s = 0.02\n[damper]\ngap_m = 1e-4\n";

/// Every command that writes a file, with `--scenario s.toml` and the given output.
fn commands_writing(out: &str) -> Vec<Vec<String>> {
    let sc = ["--scenario", "s.toml"];
    let v = |a: &[&str]| -> Vec<String> {
        a.iter()
            .chain(&sc)
            .chain(&["--out", out])
            .map(|s| s.to_string())
            .collect()
    };
    vec![
        v(&["run"]),
        v(&["sweep", "--ratios", "1:1:1"]),
        v(&["map", "--ratios", "1:1:1", "--gaps-mm", "0.1:0.1:0.1"]),
        v(&["poincare", "--ratio", "1", "--gap-mm", "0.1"]),
        v(&[
            "bifurcation",
            "--param",
            "ratio",
            "--values",
            "1:1:1",
            "--gap-mm",
            "0.1",
        ]),
        v(&[
            "ensemble",
            "--ratio",
            "1",
            "--gap-mm",
            "0.1",
            "--members",
            "2",
        ]),
        v(&["lobes", "--rpm", "1000:2000:500"]),
        v(&["frf", "--band-hz", "500:600:50"]),
        v(&["orbit", "--ratio", "1", "--gap-mm", "0.08"]),
        v(&[
            "continue", "--ratio", "1", "--param", "gap-mm", "--from", "0.08", "--to", "0.081",
        ]),
        v(&[
            "continue2",
            "--from-point",
            "ratio=1,gap-mm=0.09489",
            "--kind",
            "torus",
            "--ratios",
            "0.99:1.01",
        ]),
        v(&[
            "placement",
            "--positions-mm",
            "100:100:1",
            "--gaps-mm",
            "0.1:0.1:0.1",
            "--ratios",
            "1:1:1",
        ]),
    ]
}

#[test]
fn regression_every_command_refuses_an_output_that_is_its_scenario() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fs::write(d.join("s.toml"), SCENARIO).unwrap();
    std::os::unix::fs::symlink("s.toml", d.join("link.csv")).unwrap();
    for out in ["s.toml", "link.csv"] {
        for args in commands_writing(out) {
            let args: Vec<&str> = args.iter().map(String::as_str).collect();
            let t = std::time::Instant::now();
            let o = vibrobar_in(d, &args);
            assert!(!o.status.success(), "{args:?} succeeded");
            assert!(
                stderr(&o).contains("is also an input"),
                "{args:?}: {}",
                stderr(&o)
            );
            assert!(t.elapsed().as_secs_f64() < 5.0, "{args:?} refused late");
            assert_eq!(fs::read_to_string(d.join("s.toml")).unwrap(), SCENARIO);
            assert_eq!(names(d), ["link.csv", "s.toml"], "{args:?} left files");
        }
    }
}

#[test]
fn regression_derived_output_that_is_the_scenario_is_refused() {
    // `poincare --out x.csv` also writes x.npy: a scenario named x.npy must survive.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fs::write(d.join("x.npy"), SCENARIO).unwrap();
    let o = vibrobar_in(
        d,
        &[
            "poincare",
            "--scenario",
            "x.npy",
            "--ratio",
            "1",
            "--gap-mm",
            "0.1",
            "--out",
            "x.csv",
        ],
    );
    assert_fails_with(&o, &["is also an input"]);
    assert_eq!(fs::read_to_string(d.join("x.npy")).unwrap(), SCENARIO);
}

#[test]
fn regression_sweep_and_map_without_forcing_refuse_before_any_journal() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fs::write(d.join("z.toml"), "[forcing]\namplitude_n = 0\n").unwrap();
    for args in [
        &[
            "sweep",
            "--scenario",
            "z.toml",
            "--ratios",
            "1:1:1",
            "--gap-mm",
            "0.1",
            "--out",
            "z.csv",
        ][..],
        &[
            "map",
            "--scenario",
            "z.toml",
            "--ratios",
            "1:1:1",
            "--gaps-mm",
            "0.1:0.1:0.1",
            "--out",
            "z.csv",
        ][..],
        &[
            "map",
            "--friction",
            "none",
            "--ratios",
            "1:1:1",
            "--gaps-mm",
            "0.1:0.1:0.1",
            "--threads",
            "0",
            "--out",
            "z.csv",
        ][..],
    ] {
        let o = vibrobar_in(d, args);
        assert!(!o.status.success(), "{args:?}");
        let e = stderr(&o);
        assert!(
            e.contains("forcing.amplitude_n") || e.contains("--threads"),
            "{args:?}: {e}"
        );
        assert_eq!(names(d), ["z.toml"], "{args:?} left files: {e}");
    }
}

/// Start `args` in `dir`, wait until `ready(dir)`, send SIGINT, and return its output.
fn interrupt(dir: &Path, args: &[&str], ready: impl Fn(&Path) -> bool) -> Output {
    let mut child = bin()
        .current_dir(dir)
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = std::time::Instant::now();
    while !ready(dir) {
        if let Some(st) = child.try_wait().unwrap() {
            panic!("{args:?} ended ({st:?}) before it was interrupted");
        }
        if t0.elapsed().as_secs() > 60 {
            // SAFETY: signalling our own child.
            unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGKILL) };
            panic!("{args:?} never got ready");
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    // SAFETY: signalling our own child.
    unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGINT) };
    child.wait_with_output().unwrap()
}

fn journal_rows(p: &Path) -> usize {
    fs::read_to_string(p)
        .map(|t| t.lines().count().saturating_sub(2))
        .unwrap_or(0)
}

/// About 1.5 s of rk4 work on two threads: long enough to be interrupted in the middle.
const MAP: [&str; 14] = [
    "map",
    "--friction",
    "none",
    "--solver",
    "rk4",
    "--ratios",
    "0.95:1.05:0.01",
    "--gaps-mm",
    "0.1:0.5:0.1",
    "--duration",
    "0.5",
    "--threads",
    "2",
    "--out",
];

#[test]
fn regression_sigint_during_map_keeps_a_resumable_journal_and_no_partial() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut args = MAP.to_vec();
    args.push("m.csv");
    let journal: PathBuf = d.join("m.csv.journal");
    let o = interrupt(d, &args, |_| journal_rows(&journal) >= 3);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(130), "{e}");
    assert!(
        e.contains("interrupted: the map to m.csv") && e.contains("kept m.csv.journal"),
        "{e}"
    );
    let left = names(d);
    assert!(left.contains(&"m.csv.journal".to_string()), "{left:?}");
    assert!(!left.iter().any(|n| n.contains("partial")), "{left:?}");
    assert!(!left.contains(&"m.csv".to_string()), "{left:?}");
    assert!(!left.iter().any(|n| n.ends_with(".lock")), "{left:?}");
    // Resume completes it, byte-identical to an uninterrupted map.
    args.push("--resume");
    let o = vibrobar_in(d, &args);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("resuming"), "{}", stderr(&o));
    args.pop();
    args.pop();
    args.push("whole.csv");
    let o = vibrobar_in(d, &args);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        fs::read(d.join("m.csv")).unwrap(),
        fs::read(d.join("whole.csv")).unwrap()
    );
}

#[test]
fn regression_sigint_during_poincare_and_paper_leaves_no_partial() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Long enough to be interrupted while it computes (it prints nothing before it is done).
    let o = interrupt(
        d,
        &[
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
            "30",
            "--out",
            "p.csv",
        ],
        |_| {
            std::thread::sleep(std::time::Duration::from_millis(300));
            true
        },
    );
    assert_eq!(o.status.code(), Some(130), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("interrupted: the poincare to p.csv"),
        "{}",
        stderr(&o)
    );
    assert_eq!(names(d), Vec::<String>::new());
    // `paper --quick`: interrupted while it computes. (Its figures are drawn by the plotting
    // library into `NAME.partial.png` files that the interrupt cleanup does not know of until
    // the figure code registers them with `vibrobar_io::track_partial`.)
    let out = d.join("paper");
    let o = interrupt(d, &["paper", "--quick", "--out", "paper"], |_| {
        std::thread::sleep(std::time::Duration::from_millis(100));
        true
    });
    assert_eq!(o.status.code(), Some(130), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("interrupted: the paper to paper"),
        "{}",
        stderr(&o)
    );
    let left: Vec<String> = if out.exists() { names(&out) } else { vec![] };
    assert!(
        o.status.code() == Some(130) || o.status.success(),
        "{:?}: {}",
        o.status,
        stderr(&o)
    );
    assert!(!left.iter().any(|n| n.contains("partial")), "{left:?}");
}

#[test]
fn regression_duration_1e308_error_shows_the_value_given_not_inf() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for args in [
        &["run", "--duration", "1e308", "--out", "r.csv"][..],
        &[
            "map",
            "--friction",
            "none",
            "--ratios",
            "1:1:1",
            "--gaps-mm",
            "0.1:0.1:0.1",
            "--duration",
            "1e308",
            "--out",
            "m.csv",
        ][..],
    ] {
        let o = vibrobar_in(d, args);
        let e = stderr(&o);
        assert!(!o.status.success(), "{args:?}");
        assert!(e.contains("1e308 s") && !e.contains("inf"), "{args:?}: {e}");
        assert_eq!(names(d), Vec::<String>::new());
    }
}

#[test]
fn regression_rk4_penetration_in_sweep_and_map_warns_once_with_the_worst_point() {
    // Only `run` warned; a sweep or map of the same rk4 runs said nothing.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fs::write(
        d.join("push.toml"),
        "[forcing]\nstatic_force_n = 1e6\n[damper]\ngap_m = 1e-4\n",
    )
    .unwrap();
    let common = [
        "--scenario",
        "push.toml",
        "--solver",
        "rk4",
        "--duration",
        "0.01",
        "--ratios",
        "0.9:1.1:0.1",
    ];
    for (cmd, extra, runs) in [
        ("sweep", &[][..], 3),
        ("map", &["--gaps-mm", "0.1:0.2:0.1"][..], 6),
    ] {
        let mut args = vec![cmd];
        args.extend(common);
        args.extend(extra);
        args.extend(["--out", "o.csv"]);
        let o = vibrobar_in(d, &args);
        let e = stderr(&o);
        assert!(o.status.success(), "{cmd}: {e}");
        assert_eq!(e.matches("warning: the ball went").count(), 1, "{cmd}: {e}");
        assert!(
            e.contains("% of the gap (warning above 1 %) at ratio")
                && e.contains(&format!("the worst of {runs} such runs")),
            "{cmd}: {e}"
        );
        fs::remove_file(d.join("o.csv")).unwrap();
    }
    // The paper's own rk4 sweep stays below the limit: no warning.
    let o = vibrobar_in(
        d,
        &[
            "sweep",
            "--solver",
            "rk4",
            "--duration",
            "0.05",
            "--ratios",
            "1:1:1",
            "--gap-mm",
            "0.1",
            "--out",
            "p.csv",
        ],
    );
    assert!(
        o.status.success() && !stderr(&o).contains("warning"),
        "{}",
        stderr(&o)
    );
}
