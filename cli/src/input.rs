//! Reading the tool's input files, and its progress bar.

use std::io;
use std::path::Path;

use hough_heading_recordings::Fatal;
use indicatif::{ProgressBar, ProgressStyle};

/// Reads a whole input file (`-` = stdin), naming it on failure.
pub fn read_input(path: &Path) -> Result<Vec<u8>, Fatal> {
    if path == Path::new("-") {
        let mut bytes = Vec::new();
        io::Read::read_to_end(&mut io::stdin(), &mut bytes)
            .map_err(|e| Fatal::io(format!("stdin: {e}")))?;
        return Ok(bytes);
    }
    std::fs::read(path).map_err(|e| Fatal::io(format!("{}: cannot read: {e}", path.display())))
}

/// The lines of a pair file: split on `\n`, `\r` stripped, without the empty
/// piece after a final newline.
pub fn lines(bytes: &[u8]) -> Vec<&[u8]> {
    let mut lines: Vec<&[u8]> = bytes
        .split(|&b| b == b'\n')
        .map(|l| l.strip_suffix(b"\r").unwrap_or(l))
        .collect();
    if lines.last().is_some_and(|l| l.is_empty()) {
        lines.pop();
    }
    lines
}

/// A progress bar on stderr (drawn only on a terminal).
pub fn progress(len: usize, quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(len as u64);
    if let Ok(style) =
        ProgressStyle::with_template("{bar:40} {pos}/{len} pairs {per_sec} eta {eta}")
    {
        bar.set_style(style);
    }
    bar
}
