//! `scans PAIRS.jsonl...`: one JSON line per scan pair of a pair file, and
//! with `--summary` the comparison with the files' ground truth.

use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::Args;
use hough_heading::Mode;
use hough_heading_recordings::engine::Engine;
use hough_heading_recordings::line::OutputLine;
use hough_heading_recordings::options::{BeamArgs, EstimatorArgs, ScanGridArgs};
use hough_heading_recordings::pairs::{self, PairRecord, Truth};
use hough_heading_recordings::Fatal;

use crate::input::{lines, progress, read_input};
use crate::jobs::{JobsArgs, Workers};
use crate::summary::{Method, Summary};

/// `scans PAIRS.jsonl...`.
#[derive(Clone, Debug, Args)]
pub struct ScansArgs {
    /// Pair files, one JSON object per line (format of ../shared/data/README.md);
    /// `-` reads stdin. With several files each output line also names its
    /// file.
    #[arg(required = true, num_args = 1..)]
    pub pairs: Vec<PathBuf>,
    /// Compare with the files' ground truth; print a table per file to
    /// stderr, and one over all files when there are several.
    #[arg(long)]
    pub summary: bool,
    /// Also run the other mode, for the summary (stdout keeps `--mode`).
    #[arg(long)]
    pub compare: bool,
    /// Only the first N lines.
    #[arg(long, value_name = "N")]
    pub limit: Option<usize>,
    /// No progress bar or timing line.
    #[arg(long, short)]
    pub quiet: bool,
    /// Threads.
    #[command(flatten)]
    pub jobs: JobsArgs,
    /// How scans become grids.
    #[command(flatten)]
    pub grid: ScanGridArgs,
    /// What the beams do after the grid estimate.
    #[command(flatten)]
    pub beams: BeamArgs,
    /// Estimator options.
    #[command(flatten)]
    pub estimator: EstimatorArgs,
}

/// Runs `scans`; the number of failed lines.
///
/// # Errors
/// Unreadable pair files, unusable options.
pub fn run(args: &ScansArgs) -> Result<usize, Fatal> {
    let mut workers = Workers::new(args.jobs.threads(), || {
        args.estimator.engine(args.grid.size)
    })?;
    let stdout = io::stdout();
    let mut out = BufWriter::new(stdout.lock());
    let mut pooled = Summary::default();
    let mut failed = 0;
    let several = args.pairs.len() > 1;
    for path in &args.pairs {
        let file = several.then(|| path.display().to_string());
        let (file_failed, summary) = scans_file(args, path, file, &mut workers, &mut out)?;
        failed += file_failed;
        if args.summary {
            eprintln!(
                "\n{}: {}\n\n{}\n{}",
                path.display(),
                setup_line(args),
                summary.table(),
                summary.fits_better_pairs()
            );
            pooled.extend(summary);
        }
    }
    if args.summary && several {
        eprintln!(
            "\nall {} files pooled: {}\n\n{}",
            args.pairs.len(),
            setup_line(args),
            pooled.table()
        );
    }
    Ok(failed)
}

/// The set-up of a scans run, for the summary heading.
fn setup_line(args: &ScansArgs) -> String {
    let window = match args.grid.cell {
        Some(c) => format!("cell {c} m"),
        None => "window R = p90 of valid ranges, 2–40 m".into(),
    };
    format!(
        "{}², N_θ = {}, {window}{}{}{}",
        args.grid.size,
        args.estimator.n_theta,
        if args.grid.connect > 0.0 {
            ", segments"
        } else {
            ""
        },
        if args.grid.disc { ", disc" } else { "" },
        if args.estimator.no_verify {
            ", no verification"
        } else {
            ""
        },
    )
}

/// What the estimating threads make of one line of a pair file.
struct LineResult {
    /// The scans, parsed.
    pair: Result<PairRecord, String>,
    /// The estimates in each mode.
    result: Result<Vec<pairs::PairEstimate>, String>,
    /// The ground truth (`--summary` only).
    truth: Option<Result<Truth, String>>,
}

/// Estimates every pair of one file, writing the JSON lines to `out`;
/// returns the failed lines and the file's summary. The lines are estimated
/// in batches spread over `workers`, and each batch is written (and summed
/// up) in the file's order.
fn scans_file(
    args: &ScansArgs,
    path: &Path,
    file: Option<String>,
    workers: &mut Workers<Box<dyn Engine>>,
    out: &mut impl Write,
) -> Result<(usize, Summary), Fatal> {
    let options = args.grid.options(&args.beams)?;
    let bytes = read_input(path)?;
    let mut lines = lines(&bytes);
    if let Some(limit) = args.limit {
        lines.truncate(limit);
    }
    let primary: Mode = args.estimator.mode.into();
    let modes: Vec<Mode> = if args.compare {
        let other = match primary {
            Mode::Improved => Mode::Paper,
            Mode::Paper => Mode::Improved,
        };
        vec![primary, other]
    } else {
        vec![primary]
    };
    let bar = progress(lines.len(), args.quiet);
    let mut summary = Summary::default();
    let mut failed = 0;
    let start = Instant::now();
    let batch = workers.batch();
    for (batch_index, batch_lines) in lines.chunks(batch).enumerate() {
        let first = batch_index * batch;
        let results = workers.map(batch_lines, |engine, i, line| {
            let index = first + i;
            let pair = serde_json::from_slice::<PairRecord>(line)
                .map_err(|e| format!("line {}: malformed pair: {e}", index + 1));
            let result = pair.as_ref().map_err(Clone::clone).and_then(|pair| {
                pairs::estimate(engine.as_mut(), pair, &options, &modes)
                    .map_err(|e| format!("line {}: {e}", index + 1))
            });
            let truth = (args.summary && result.is_ok() && pair.is_ok())
                .then(|| serde_json::from_slice::<Truth>(line).map_err(|e| e.to_string()));
            bar.inc(1);
            LineResult {
                pair,
                result,
                truth,
            }
        });
        for (i, line) in results.into_iter().enumerate() {
            let index = first + i;
            let LineResult {
                pair,
                result,
                truth,
            } = line;
            let mut output = match &result {
                Ok(estimates) => OutputLine::of(index, &estimates[0]),
                Err(message) => {
                    failed += 1;
                    bar.suspend(|| eprintln!("hough-heading: {}: {message}", path.display()));
                    OutputLine::error(index, message.clone())
                }
            };
            output.file.clone_from(&file);
            let text = serde_json::to_string(&output)
                .map_err(|e| Fatal::io(format!("JSON output: {e}")))?;
            if writeln!(out, "{text}").is_err() {
                // stdout closed (e.g. piped into `head`): stop quietly.
                return Ok((failed, summary));
            }
            if args.summary {
                match (&result, &pair, truth) {
                    (Ok(estimates), Ok(pair), Some(Ok(truth))) => {
                        let with_methods: Vec<(Method, &pairs::PairEstimate)> = modes
                            .iter()
                            .zip(estimates)
                            .map(|(m, e)| {
                                let method = match m {
                                    Mode::Improved => Method::Improved,
                                    Mode::Paper => Method::Paper,
                                };
                                (method, e)
                            })
                            .collect();
                        summary.add(index, &truth, pair, &with_methods);
                    }
                    (Ok(_), _, Some(Err(e))) => {
                        bar.suspend(|| {
                            eprintln!(
                                "hough-heading: line {}: no ground truth ({e}); not in the summary",
                                index + 1
                            )
                        });
                        summary.add_error();
                    }
                    _ => summary.add_error(),
                }
            }
        }
    }
    let _ = out.flush();
    bar.finish_and_clear();
    let elapsed = start.elapsed().as_secs_f64();
    if !args.quiet {
        let threads = workers.threads();
        eprintln!(
            "hough-heading: {}: {} pairs ({failed} failed) in {elapsed:.2} s: {:.0} pairs/s, {} mode(s), \
             {threads} thread{}",
            path.display(),
            lines.len(),
            lines.len() as f64 / elapsed.max(1e-9),
            modes.len(),
            if threads == 1 { "" } else { "s" }
        );
    }
    Ok((failed, summary))
}
