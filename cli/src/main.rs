//! `hough-heading`: see `hough-heading --help` and [`hough_heading_cli`].

fn main() -> std::process::ExitCode {
    // Output piped into a reader that stops early (`| head`): end of the
    // process by SIGPIPE, as other Unix tools do, not a panic.
    #[cfg(unix)]
    sigpipe::reset();
    hough_heading_cli::main()
}
