//! `hough-heading`: see `hough-heading --help` and [`hough_heading_cli`].

use std::process::ExitCode;

use clap::Parser;
use hough_heading_cli::{Cli, EXIT_FATAL, EXIT_PAIR_ERRORS};

/// Parses the arguments, runs, and maps the outcome to the exit status.
fn main() -> ExitCode {
    // Output piped into a reader that stops early (`| head`): end of the
    // process by SIGPIPE, as other Unix tools do, not a panic.
    #[cfg(unix)]
    sigpipe::reset();
    let cli = Cli::parse();
    match cli.command.run() {
        Ok(0) => ExitCode::SUCCESS,
        Ok(_) => ExitCode::from(EXIT_PAIR_ERRORS),
        Err(e) => {
            eprintln!("hough-heading: error: {e}");
            ExitCode::from(EXIT_FATAL)
        }
    }
}
