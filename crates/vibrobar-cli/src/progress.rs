//! Terminal progress bar for long runs: rate and ETA, drawn on stderr only when stderr is a
//! terminal (so logs and CI output stay clean). The core reports progress through a
//! `Fn(done, total)` callback; [`Progress::callback`] adapts the bar to it.
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;

/// A progress bar, hidden when stderr is not a terminal.
pub struct Progress {
    bar: ProgressBar,
    offset: u64,
}

impl Progress {
    /// A bar for `total` items, `message` shown before it. `already` items are done (resume).
    pub fn new(message: &str, total: usize, already: usize) -> Progress {
        let bar = ProgressBar::new(total as u64);
        if std::io::stderr().is_terminal() {
            bar.set_draw_target(ProgressDrawTarget::stderr());
        } else {
            bar.set_draw_target(ProgressDrawTarget::hidden());
        }
        bar.set_style(
            ProgressStyle::with_template(
                "{msg} [{elapsed_precise}] {wide_bar} {pos}/{len} {per_sec} ETA {eta}",
            )
            .expect("valid template"),
        );
        bar.set_message(message.to_string());
        bar.set_position(already as u64);
        bar.reset_eta();
        Progress {
            bar,
            offset: already as u64,
        }
    }

    /// `(done, total)` callback for the core; `done` and `total` count from this bar's start
    /// (the batch runner's total includes its solid runs).
    pub fn callback(&self) -> impl Fn(usize, usize) + Sync + '_ {
        move |done, total| {
            self.bar.set_length(self.offset + total as u64);
            self.bar.set_position(self.offset + done as u64)
        }
    }

    /// Count one more item.
    pub fn inc(&self) {
        self.bar.inc(1);
    }

    /// Remove the bar.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}
