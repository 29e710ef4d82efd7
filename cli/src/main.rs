//! `hough-heading`: see `hough-heading --help` and [`host_tests::cli`].

fn main() -> std::process::ExitCode {
    host_tests::cli::main()
}
