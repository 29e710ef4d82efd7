//! `hough-heading`: see `hough-heading --help` and [`hough_heading_cli`].

fn main() -> std::process::ExitCode {
    hough_heading_cli::main()
}
