//! `reference`: one scan of a pair file as the bytes a firmware stores (a
//! `ScanReference`: the reference, its free space, its raster and the scan
//! itself), to be read with `ScanReference::from_bytes` (a `const fn`: a
//! `static` in flash) for a capacity of at least the scan's readings.

use std::path::PathBuf;

use clap::Args;
use hough_heading::stages::SCAN_REFERENCE_FORMAT;

use hough_heading_recordings::engine::{engine, View, CONFIGURATIONS};
use hough_heading_recordings::options::{BeamArgs, ScanGridArgs};
use hough_heading_recordings::pairs::PairRecord;
use hough_heading_recordings::Fatal;

/// `reference --scans PAIRS.jsonl --out FILE`.
#[derive(Clone, Debug, Args)]
pub struct ReferenceArgs {
    /// Pair file (format of ../shared/data/README.md) holding the scan.
    #[arg(long, value_name = "PAIRS.jsonl")]
    pub scans: PathBuf,
    /// Line of the pair file (0 = the first).
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub line: usize,
    /// Which scan of the pair: 1 (`scan1`) or 2 (`scan2`).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u8).range(1..=2))]
    pub scan: u8,
    /// θ steps over the full circle (the firmware's `N_THETA`).
    #[arg(long, default_value_t = 360)]
    pub n_theta: usize,
    /// How the scan becomes a grid (`--size`, `--cell`, `--connect`,
    /// `--disc`). Without `--cell` the window is the 90th percentile of this
    /// scan's valid ranges; the raster is stored with the reference, so the
    /// firmware draws its new scans with the same one
    /// (`ScanReference::raster`).
    #[command(flatten)]
    pub grid: ScanGridArgs,
    /// Output file (e.g. `dock.hhs`).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
}

/// Writes the scan reference and reports it on stderr.
///
/// # Errors
/// An unknown configuration, an unreadable pair file, a missing line, a
/// scan without beams or an unusable cell size, an unwritable output.
pub fn run(args: &ReferenceArgs) -> Result<(), Fatal> {
    let size = args.grid.size;
    let mut engine = engine(size, args.n_theta).ok_or_else(|| {
        Fatal::usage(format!(
            "--size {size} --n-theta {}: not a compiled configuration ({CONFIGURATIONS:?})",
            args.n_theta
        ))
    })?;
    let text = std::fs::read_to_string(&args.scans)
        .map_err(|e| Fatal::io(format!("{}: {e}", args.scans.display())))?;
    let line = text.lines().nth(args.line).ok_or_else(|| {
        Fatal::usage(format!(
            "{}: no line {} (the file has {})",
            args.scans.display(),
            args.line,
            text.lines().count()
        ))
    })?;
    let pair: PairRecord = serde_json::from_str(line).map_err(|e| {
        Fatal::io(format!(
            "{} line {}: not a scan pair: {e}",
            args.scans.display(),
            args.line
        ))
    })?;
    let record = if args.scan == 1 {
        &pair.scan1
    } else {
        &pair.scan2
    };
    let ranges = record.ranges();
    if ranges.is_empty() {
        return Err(Fatal::io(format!(
            "{} line {}: scan {} has no beams",
            args.scans.display(),
            args.line,
            args.scan
        )));
    }
    let scan = record.scan(&ranges);
    let raster = args
        .grid
        .options(&BeamArgs::default())?
        .raster(&[scan], size)
        .ok_or_else(|| Fatal::usage("the cell size must be finite and positive"))?;
    let stats = engine.rasterize(View::First, &scan, &raster);
    let bytes = engine
        .scan_reference(View::First, &raster, &scan)
        .map_err(|e| Fatal::io(format!("the scan reference could not be written: {e}")))?;
    std::fs::write(&args.out, &bytes)
        .map_err(|e| Fatal::io(format!("{}: {e}", args.out.display())))?;
    eprintln!(
        "{}: scan reference format {SCAN_REFERENCE_FORMAT}, {} bytes, {size}² cells of {:.4} m, \
         N_θ = {}, {} of {} beams kept, {} readings stored (read it with BEAMS ≥ {}) \
         ({} line {}, scan {})",
        args.out.display(),
        bytes.len(),
        raster.cell(),
        args.n_theta,
        stats.kept,
        stats.beams,
        ranges.len(),
        ranges.len(),
        args.scans.display(),
        args.line,
        args.scan
    );
    Ok(())
}
