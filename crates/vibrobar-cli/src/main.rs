//! `vibrobar`: thin wrapper mapping errors to a message on stderr and a non-zero exit.

use clap::Parser;
use vibrobar_cli::app::{dispatch, Cli};

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    match dispatch(cli) {
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
