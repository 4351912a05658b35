//! `vibrobar`: thin wrapper mapping errors to a message on stderr and a non-zero exit.

use vibrobar_cli::app;

fn main() -> std::process::ExitCode {
    die_quietly_on_broken_pipe();
    let cli = app::parse();
    app::install_interrupt_cleanup(cli.command.describe());
    match app::dispatch(cli) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            for cause in e.chain().skip(1) {
                eprintln!("  caused by: {cause}");
            }
            std::process::ExitCode::FAILURE
        }
    }
}

/// Rust starts programs with SIGPIPE ignored, so a write to a closed pipe (`vibrobar beam |
/// head -1`) returns EPIPE and `println!` panics ("failed printing to stdout", status 101).
/// Unix tools instead end quietly by SIGPIPE (the shell reports status 141). Restoring the
/// default disposition does that for every write to stdout and stderr, progress bars included,
/// without wrapping each print; files written so far are atomic or journalled, so nothing
/// half-written looks complete.
#[cfg(unix)]
fn die_quietly_on_broken_pipe() {
    // SAFETY: first thing in `main`, before any other thread exists; `SIG_DFL` is a valid
    // disposition for SIGPIPE.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

/// Elsewhere a broken pipe stays an I/O error.
#[cfg(not(unix))]
fn die_quietly_on_broken_pipe() {}
