//! What every end-to-end test of the `vibrobar` binary needs: start it (plainly, in a folder,
//! with environment variables, or under a timeout and a memory limit), read its stderr, and
//! assert that it succeeded or failed with a message. Each test crate uses only some of these.
#![allow(dead_code)]

use std::fs;
use std::io::Read;
use std::path::Path;
use std::process::{Child, Command, ExitStatus, Output, Stdio};
use std::time::{Duration, Instant};

pub const BIN: &str = env!("CARGO_BIN_EXE_vibrobar");

/// The binary, not yet started.
pub fn bin() -> Command {
    Command::new(BIN)
}

/// Run `vibrobar args` to its end and collect its output.
pub fn vibrobar(args: &[&str]) -> Output {
    bin().args(args).output().expect("binary runs")
}

/// Run `vibrobar args`; panic with its stdout and stderr unless it succeeded.
pub fn vibrobar_ok(args: &[&str]) -> Output {
    let o = vibrobar(args);
    assert!(
        o.status.success(),
        "vibrobar {args:?} failed: {}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

/// Run `vibrobar args` in `dir`.
pub fn vibrobar_in(dir: &Path, args: &[&str]) -> Output {
    bin()
        .current_dir(dir)
        .args(args)
        .output()
        .expect("binary runs")
}

/// Run `vibrobar args` with extra environment variables.
pub fn vibrobar_env<S: AsRef<std::ffi::OsStr>>(args: &[S], envs: &[(&str, &str)]) -> Output {
    let mut c = bin();
    c.args(args);
    for (k, v) in envs {
        c.env(k, v);
    }
    c.output().expect("binary runs")
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The run succeeded; otherwise panic with its stdout and stderr.
pub fn assert_ok(o: &Output) {
    assert!(
        o.status.success(),
        "failed: {}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// The run failed and its stderr holds every `want`; returns that stderr.
pub fn assert_fails_with(o: &Output, want: &[&str]) -> String {
    let err = stderr(o);
    assert!(!o.status.success(), "succeeded; stderr: {err}");
    for w in want {
        assert!(err.contains(w), "stderr lacks {w:?}: {err}");
    }
    err
}

/// The sorted names in `dir`.
pub fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// What a run under [`run_limited`] gave.
pub struct Run {
    pub status: ExitStatus,
    pub stdout: String,
    pub stderr: String,
    pub wall: Duration,
}

/// Cap the child's address space at 4 GiB (on Unix), so a regression that allocates without a
/// limit fails the test instead of eating the machine.
pub fn limit_memory(cmd: &mut Command) {
    #[cfg(unix)]
    {
        use std::os::unix::process::CommandExt;
        // SAFETY: only async-signal-safe setrlimit between fork and exec.
        unsafe {
            cmd.pre_exec(|| {
                let lim = libc::rlimit {
                    rlim_cur: 4 << 30,
                    rlim_max: 4 << 30,
                };
                libc::setrlimit(libc::RLIMIT_AS, &lim);
                Ok(())
            });
        }
    }
}

/// Wait for `child` (started at `t0`); kill it and panic if it has not ended within `timeout`.
pub fn wait_or_kill(
    child: &mut Child,
    args: &[&str],
    t0: Instant,
    timeout: Duration,
) -> ExitStatus {
    loop {
        if let Some(s) = child.try_wait().unwrap() {
            return s;
        }
        if t0.elapsed() > timeout {
            child.kill().ok();
            child.wait().ok();
            panic!("vibrobar {args:?} did not end within {timeout:?}");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Run the binary in `dir` under [`limit_memory`] and a wall-clock `timeout` (see
/// [`wait_or_kill`]), collecting stdout and stderr.
pub fn run_limited(dir: &Path, args: &[&str], timeout: Duration) -> Run {
    let mut cmd = bin();
    cmd.args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    limit_memory(&mut cmd);
    let t0 = Instant::now();
    let mut child = cmd.spawn().expect("binary starts");
    let mut out = child.stdout.take().unwrap();
    let mut err = child.stderr.take().unwrap();
    let t_out = std::thread::spawn(move || {
        let mut s = String::new();
        out.read_to_string(&mut s).ok();
        s
    });
    let t_err = std::thread::spawn(move || {
        let mut s = String::new();
        err.read_to_string(&mut s).ok();
        s
    });
    let status = wait_or_kill(&mut child, args, t0, timeout);
    Run {
        status,
        stdout: t_out.join().unwrap(),
        stderr: t_err.join().unwrap(),
        wall: t0.elapsed(),
    }
}
