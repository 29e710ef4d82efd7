//! The `hough-heading` command-line tool: rotation (and translation) between
//! two binary images or laser scans, a demo on bundled data, a real-data
//! summary and figures. The binary (`src/main.rs`) calls [`main`]; the
//! modules are public for the tool's own tests.
//!
//! Exit status: 0 success; 1 some scan pairs failed (their output lines have
//! `"status": "error"`); 2 usage error, unreadable file, wrong image size or
//! empty image.
//!
//! On bare-metal targets this library is empty (`no_std`): the package is a
//! default workspace member, and `cargo build --lib --target <bare-metal>`
//! must work from the repository root.
#![cfg_attr(target_os = "none", no_std)]
#![cfg(not(target_os = "none"))]

pub mod demo;
pub mod engine;
pub mod images;
pub mod jobs;
pub mod log;
pub mod mcu;
pub mod plot;
pub mod scans;
pub mod stats;
pub mod stored;
pub mod summary;
pub mod wire;

use std::fmt;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use clap::{Args, Parser, Subcommand, ValueEnum};
use hough_heading::{Estimate, Mode, ScaleRange, Score, Thresholds};
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;

use engine::{engine, Engine, View, CONFIGURATIONS};
use images::{Fit, Threshold};
use jobs::{JobsArgs, Workers};
use scans::{OutputLine, PairRecord, RasterOptions, Truth};
use summary::{Method, Summary};

/// Exit status: some scan pairs failed.
pub const EXIT_PAIR_ERRORS: u8 = 1;
/// Exit status: usage error or an unusable input file.
pub const EXIT_FATAL: u8 = 2;

const AFTER_HELP: &str = "\
Compiled configurations (--size × --n-theta): 64, 128, 256 × 180, 360, 720.

Conventions: α is the counter-clockwise rotation of the scene (a point p of A
appears in B at R(α)·p + t, t in pixels, x right, y up, origin at the image
centre). For scans, dθ = −α is the robot's heading change and (dx, dy) its
displacement in the frame of scan 1, as in the pair files.

Exit status: 0 success; 1 some scan pairs failed (their output lines say
\"status\": \"error\"); 2 usage error, unreadable file, wrong image size or empty
image.";

/// Rotation (and translation) between two binary images or 2D laser scans,
/// by the doubled-line Hough signature (no_std fixed-point library).
#[derive(Debug, Parser)]
#[command(name = "hough-heading", version, after_help = AFTER_HELP)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Rotation of image B relative to image A (PBM P1/P4, PNG, PGM).
    Images(ImagesArgs),
    /// One JSON line per scan pair of a pair file (`-` reads stdin).
    Scans(ScansArgs),
    /// Runs on the bundled example data and prints a short report.
    Demo(DemoArgs),
    /// PNG figures: grids, accumulators, signatures, correlation, asymmetry.
    Plot(PlotArgs),
    /// Scan pairs for the firmware (`export`), and its results checked (`check`).
    Mcu(mcu::McuArgs),
    /// Motion between the scans of a recording: a CARMEN log (`.gz` too), a
    /// ROS 1 bag or a ROS 2 bag (MCAP or SQLite); one JSON line per scan pair.
    Log(Box<log::LogArgs>),
    /// A raw lidar capture (LD06, RPLIDAR, YDLIDAR bytes) as a CARMEN log,
    /// one `ROBOTLASER1` line per revolution.
    Wire(wire::WireArgs),
    /// One scan of a pair file as a stored scan reference for the firmware
    /// (`ScanReference` bytes: the reference, its free space, raster and
    /// scan).
    Reference(stored::StoredArgs),
}

/// Which pipeline.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ModeArg {
    /// Two-bin D, sub-step peak, column-profile direction test, translation.
    Improved,
    /// The paper as written (asymmetry-map direction test, no translation).
    Paper,
}

impl From<ModeArg> for Mode {
    fn from(m: ModeArg) -> Mode {
        match m {
            ModeArg::Improved => Mode::Improved,
            ModeArg::Paper => Mode::Paper,
        }
    }
}

/// Options shared by every estimating subcommand.
#[derive(Clone, Debug, Args)]
pub struct EstimatorArgs {
    /// Pipeline.
    #[arg(long, value_enum, default_value_t = ModeArg::Improved)]
    pub mode: ModeArg,
    /// θ steps over the full circle: 180, 360 or 720.
    #[arg(long = "n-theta", default_value_t = 360)]
    pub n_theta: usize,
    /// Tuning: flag `ambiguous_axis` when the rival correlation peak reaches
    /// this fraction of the best (library default 0.9).
    #[arg(long, value_name = "RATIO")]
    pub rival_ratio: Option<f64>,
    /// Tuning: flag `ambiguous_direction` when the α vs α + 180° margin is
    /// below this (library default 0.10).
    #[arg(long, value_name = "MARGIN")]
    pub direction_margin: Option<f64>,
    /// Tuning: largest translation the profile test and the verification
    /// search, as a fraction of the ρ range (library default 0.25).
    #[arg(long, value_name = "FRACTION")]
    pub max_shift: Option<f64>,
    /// Improved mode without the verification by alignment (the
    /// correlation and the column-profile test decide alone).
    #[arg(long)]
    pub no_verify: bool,
    /// Tuning (verification): rotations whose best alignment cannot reach
    /// the best one's divided by this are not searched to the end nor
    /// listed (library default 2).
    #[arg(long, value_name = "RATIO")]
    pub alignment_ratio: Option<f64>,
    /// Tuning (verification): ambiguous unless the winner's support leads
    /// the runner-up's (≥ 5° away) by this much (library default 0.08;
    /// docs/confidence.md).
    #[arg(long, value_name = "GAP")]
    pub decision_gap: Option<f64>,
    /// Tuning (verification on scans): the weight of a free-space violation
    /// share in the support, in [0, 64] (library default 2).
    #[arg(long, value_name = "WEIGHT")]
    pub free_space_weight: Option<f64>,
    /// On scans, estimate from the grids alone, without the free space the
    /// beams saw through (as the 16 KiB Cortex-M0 firmware does).
    #[arg(long)]
    pub no_free_space: bool,

    /// Tuning (verification): `low_overlap` when the chosen pose puts less
    /// than this share of the second view within one cell of the first
    /// (library default 0.30).
    #[arg(long, value_name = "FRACTION")]
    pub min_overlap: Option<f64>,
    /// Tuning (verification): the work the translation searches of one
    /// estimate may spend, in grid rows read per sampled point, before the
    /// status becomes `search_cut` (library default 67108864 = 2^26;
    /// 4294967295: none).
    #[arg(long, value_name = "ROWS")]
    pub search_budget: Option<u32>,
}

impl EstimatorArgs {
    /// The engine for `size` with these options.
    ///
    /// # Errors
    /// An unknown configuration or a threshold outside [0, 1].
    pub fn engine(&self, size: usize) -> Result<Box<dyn Engine>, Fatal> {
        let mut engine = engine_for(size, self.n_theta)?;
        engine.set_thresholds(self.thresholds()?);
        engine.set_verification(!self.no_verify);
        engine.set_free_space(!self.no_free_space);
        Ok(engine)
    }

    /// The status thresholds of these options (the library's defaults for
    /// those not given).
    ///
    /// # Errors
    /// A threshold outside its range.
    pub fn thresholds(&self) -> Result<Thresholds, Fatal> {
        let mut t = Thresholds::DEFAULT;
        for (name, value, field) in [
            ("--rival-ratio", self.rival_ratio, &mut t.rival_ratio),
            (
                "--direction-margin",
                self.direction_margin,
                &mut t.direction_margin,
            ),
            ("--max-shift", self.max_shift, &mut t.max_shift_fraction),
            ("--min-overlap", self.min_overlap, &mut t.min_overlap),
            ("--decision-gap", self.decision_gap, &mut t.decision_gap),
        ] {
            if let Some(v) = value {
                if !(0.0..=1.0).contains(&v) {
                    return Err(Fatal::usage(format!("{name} {v}: must be in [0, 1]")));
                }
                *field = Score::from_num(v);
            }
        }
        if let Some(v) = self.alignment_ratio {
            if !(1.0..=4.0).contains(&v) {
                return Err(Fatal::usage(format!(
                    "--alignment-ratio {v}: must be in [1, 4]"
                )));
            }
            t.alignment_ratio = Score::from_num(v);
        }
        if let Some(v) = self.free_space_weight {
            if !(0.0..=64.0).contains(&v) {
                return Err(Fatal::usage(format!(
                    "--free-space-weight {v}: must be in [0, 64]"
                )));
            }
            t.free_space_weight = Score::from_num(v);
        }
        if let Some(v) = self.search_budget {
            t.search_budget = v;
        }
        Ok(t)
    }
}

/// How images are read.
#[derive(Clone, Debug, Args)]
pub struct ImageArgs {
    /// Grid side (64, 128 or 256). Default: the images' size when it is one
    /// of these; with `--fit centre`, the smallest that holds both images
    /// (256 if none does).
    #[arg(long)]
    pub size: Option<usize>,
    /// `none`: the images must have the grid's size. `centre`: centre each
    /// image in the grid, padding or cropping (the translation is reported
    /// in the original images' centred coordinates).
    #[arg(long, value_enum, default_value_t = Fit::None)]
    pub fit: Fit,
    /// Grey level (0–255) below which a pixel is occupied.
    #[arg(long, default_value_t = 128)]
    pub threshold: u8,
    /// Bright pixels are occupied (white-on-black images).
    #[arg(long)]
    pub invert: bool,
    /// Also estimate the scale B/A (improved mode), searching MIN:MAX
    /// (0.5 ≤ MIN ≤ MAX ≤ 2; without a value 0.8:1.25). Without this option
    /// the scale is 1.
    #[arg(long, value_name = "MIN:MAX", num_args = 0..=1, default_missing_value = "0.8:1.25")]
    pub scale_search: Option<String>,
}

impl ImageArgs {
    /// The scale range of `--scale-search`, if given.
    ///
    /// # Errors
    /// A usage error when the value is not `MIN:MAX` with `0.5 ≤ MIN ≤ MAX ≤ 2`.
    pub fn scale_range(&self) -> Result<Option<ScaleRange>, Fatal> {
        let Some(text) = &self.scale_search else {
            return Ok(None);
        };
        let bad = || {
            Fatal::usage(format!(
                "--scale-search {text}: expected MIN:MAX with 0.5 ≤ MIN ≤ MAX ≤ 2"
            ))
        };
        let (min, max) = text.split_once(':').ok_or_else(bad)?;
        let parse = |v: &str| v.trim().parse::<f64>().ok().filter(|v| v.is_finite());
        let (min, max) = (parse(min).ok_or_else(bad)?, parse(max).ok_or_else(bad)?);
        ScaleRange::new(
            Score::from_num(min.clamp(0.0, 4.0)),
            Score::from_num(max.clamp(0.0, 4.0)),
        )
        .map(Some)
        .map_err(|_| bad())
    }
}

/// `images A B`.
#[derive(Clone, Debug, Args)]
pub struct ImagesArgs {
    /// Reference image A.
    pub a: PathBuf,
    /// Image B.
    pub b: PathBuf,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// How images are read.
    #[command(flatten)]
    pub image: ImageArgs,
    /// Estimator options.
    #[command(flatten)]
    pub estimator: EstimatorArgs,
}

/// How scans become grids.
#[derive(Clone, Debug, Args)]
pub struct ScanGridArgs {
    /// Grid side: 64, 128 or 256.
    #[arg(long, default_value_t = 256)]
    pub size: usize,
    /// Metres per cell. Default: per pair, the window radius is the 90th
    /// percentile of both scans' valid ranges, clamped to 2–40 m.
    #[arg(long)]
    pub cell: Option<f32>,
    /// Also draw segments between neighbouring beams at most this far apart
    /// (metres); 0 draws one cell per beam. The default 0.3 m was measured
    /// best on the real scan pairs (README, "Real lidar data").
    #[arg(long, value_name = "METRES", default_value_t = scans::DEFAULT_CONNECT_M)]
    pub connect: f32,
    /// Keep only the disc inscribed in the grid.
    #[arg(long)]
    pub disc: bool,
}

/// What the beams do after the grid estimate (the commands that estimate
/// on scans; `reference` only stores a scan).
#[derive(Clone, Debug, Default, Args)]
pub struct BeamArgs {
    /// Report the grid estimate's pose as it is, without refining it on the
    /// beams' end points (`Raster::refine_on_beams`).
    #[arg(long)]
    pub no_beam_refine: bool,
    /// Keep the grid's status even when the beams prefer another listed
    /// rotation (`Raster::check_on_beams`).
    #[arg(long)]
    pub no_beam_check: bool,
}

impl ScanGridArgs {
    /// The raster options of these arguments and `beams`.
    fn options(&self, beams: &BeamArgs) -> Result<RasterOptions, Fatal> {
        if let Some(cell) = self.cell.filter(|c| !(c.is_finite() && *c > 0.0)) {
            return Err(Fatal::usage(format!(
                "--cell {cell}: must be a positive number of metres"
            )));
        }
        Ok(RasterOptions {
            cell: self.cell,
            connect: (self.connect > 0.0).then_some(self.connect),
            disc: self.disc,
            beam_refine: !beams.no_beam_refine,
            beam_check: !beams.no_beam_check,
        })
    }
}

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

/// `demo`.
#[derive(Clone, Debug, Args)]
pub struct DemoArgs {
    /// Read the demo's files from this directory (laid out as `cli/data` of
    /// the source) instead of the copy bundled in the binary.
    #[arg(long, value_name = "DIR", conflicts_with = "write_data")]
    pub data: Option<PathBuf>,
    /// Write the bundled files into DIR (created) and exit, e.g. to try the
    /// other subcommands on them.
    #[arg(long, value_name = "DIR")]
    pub write_data: Option<PathBuf>,
}

/// `plot`.
#[derive(Clone, Debug, Args)]
pub struct PlotArgs {
    /// What to plot.
    #[command(subcommand)]
    pub what: PlotWhat,
    /// Output directory (created).
    #[arg(long, short, global = true, default_value = "figures")]
    pub out: PathBuf,
}

/// `plot images` or `plot scans`.
#[derive(Clone, Debug, Subcommand)]
pub enum PlotWhat {
    /// Figures of two images.
    Images {
        /// Reference image A.
        a: PathBuf,
        /// Image B.
        b: PathBuf,
        /// How images are read.
        #[command(flatten)]
        image: ImageArgs,
        /// Estimator options.
        #[command(flatten)]
        estimator: EstimatorArgs,
    },
    /// Figures of scan pairs of a pair file.
    Scans {
        /// Pair file.
        pairs: PathBuf,
        /// 0-based line indices, comma separated.
        #[arg(long, value_delimiter = ',', required = true)]
        index: Vec<usize>,
        /// How scans become grids.
        #[command(flatten)]
        grid: ScanGridArgs,
        /// What the beams do after the grid estimate.
        #[command(flatten)]
        beams: BeamArgs,
        /// Estimator options.
        #[command(flatten)]
        estimator: EstimatorArgs,
    },
}

/// A fatal error: printed to stderr, exit status 2.
#[derive(Debug)]
pub struct Fatal(String);

impl Fatal {
    /// An unusable input or output file (the message names it).
    pub fn io(message: impl Into<String>) -> Self {
        Self(message.into())
    }

    /// An unusable option value.
    pub fn usage(message: impl Into<String>) -> Self {
        Self(message.into())
    }
}

impl fmt::Display for Fatal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

/// Parses the arguments, runs, and maps the outcome to the exit status.
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(&cli) {
        Ok(0) => ExitCode::SUCCESS,
        Ok(_) => ExitCode::from(EXIT_PAIR_ERRORS),
        Err(e) => {
            eprintln!("hough-heading: error: {e}");
            ExitCode::from(EXIT_FATAL)
        }
    }
}

/// Runs one command; the number of failed pairs.
///
/// # Errors
/// A [`Fatal`] error for unusable arguments or input files.
pub fn run(cli: &Cli) -> Result<usize, Fatal> {
    match &cli.command {
        Command::Images(args) => images_command(args).map(|()| 0),
        Command::Scans(args) => scans_command(args),
        Command::Demo(args) => demo::run(args).map(|()| 0),
        Command::Plot(args) => plot::run(args).map(|()| 0),
        Command::Mcu(args) => mcu::run(args),
        Command::Log(args) => log::run(args),
        Command::Wire(args) => wire::run(args).map(|_| 0),
        Command::Reference(args) => stored::run(args).map(|()| 0),
    }
}

/// The engine for a configuration, or a usage error listing the compiled ones.
pub fn engine_for(size: usize, n_theta: usize) -> Result<Box<dyn Engine>, Fatal> {
    engine(size, n_theta).ok_or_else(|| {
        let list: Vec<String> = CONFIGURATIONS
            .iter()
            .map(|(s, n)| format!("{s}/{n}"))
            .collect();
        Fatal::usage(format!(
            "no compiled configuration for --size {size} --n-theta {n_theta}; available \
             (size/n-theta): {}",
            list.join(", ")
        ))
    })
}

/// The result of `images`: α, status, candidates and translation of B
/// relative to A.
#[derive(Clone, Debug, Serialize)]
pub struct ImagesResult {
    /// Rotation of B relative to A, counter-clockwise, degrees in (−180, 180].
    pub alpha_deg: f64,
    /// Status word.
    pub status: &'static str,
    /// Confidence in [0, 1].
    pub confidence: f64,
    /// Candidate rotations, strongest first.
    pub candidates: Vec<CandidateJson>,
    /// Share of B's sampled cells the chosen pose puts within one cell of A
    /// (verification on).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub overlap: Option<f64>,
    /// Translation x, pixels (null when not estimated).
    pub tx_px: Option<f64>,
    /// Translation y (up), pixels.
    pub ty_px: Option<f64>,
    /// Scale of B relative to A (1 unless `--scale-search`; null when no
    /// translation was estimated).
    pub scale: Option<f64>,
    /// How well the columns agree on the translation: weighted RMS, pixels.
    pub residual_px: Option<f64>,
    /// Profile columns the translation fit kept: 3 or more cross-check each
    /// other, 2 determine it exactly (residual 0, unchecked).
    pub columns: Option<u8>,
    /// Unit vector along which the translation is not observable (a
    /// corridor), `[x, y]`; null when it is fully observable.
    pub unobservable: Option<[f64; 2]>,
    /// Grid side used.
    pub size: usize,
    /// θ steps used.
    pub n_theta: usize,
}

/// One candidate in the `images` JSON.
#[derive(Clone, Debug, Serialize)]
pub struct CandidateJson {
    /// Rotation, degrees.
    pub alpha_deg: f64,
    /// Correlation × direction share, in [0, 1].
    pub score: f64,
    /// How well this rotation's best translation aligns B onto A, in [0, 1]
    /// (verification on).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub alignment: Option<f64>,
    /// The decision score: both-way alignment on a large sample
    /// (verification on; candidates are sorted by it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub support: Option<f64>,
}

/// An engine holding two images, and each image's offset in the grid
/// (`p_grid = p_image + offset`, see [`images::Placed`]).
pub type Loaded = (Box<dyn Engine>, [(f64, f64); 2]);

/// Reads A and B and places both on a common grid: the engine holds them.
pub fn load_images(
    a: &Path,
    b: &Path,
    args: &ImageArgs,
    estimator: &EstimatorArgs,
) -> Result<Loaded, Fatal> {
    let threshold = Threshold {
        level: args.threshold,
        invert: args.invert,
    };
    let ia = images::read(a, threshold)?;
    let ib = images::read(b, threshold)?;
    place_images(
        (&a.display().to_string(), &ia),
        (&b.display().to_string(), &ib),
        args,
        estimator,
    )
}

/// Places two decoded images, each with its file name (for messages), on a
/// common grid: the engine holds them.
pub fn place_images(
    (a, ia): (&str, &images::Image),
    (b, ib): (&str, &images::Image),
    args: &ImageArgs,
    estimator: &EstimatorArgs,
) -> Result<Loaded, Fatal> {
    let supported = engine::sizes();
    let size = match args.size {
        Some(s) => s,
        None if args.fit == Fit::None => {
            if ia.width == ia.height && supported.contains(&ia.width) {
                ia.width
            } else {
                return Err(Fatal::io(format!(
                    "{}: image is {}×{}; supported grids are square, side {:?}: use --fit centre \
                     to pad/crop, or resize the image",
                    a, ia.width, ia.height, supported
                )));
            }
        }
        None => {
            let need = ia.width.max(ia.height).max(ib.width).max(ib.height);
            supported
                .iter()
                .copied()
                .find(|&s| s >= need)
                .unwrap_or(*supported.last().unwrap_or(&256))
        }
    };
    let mut engine = estimator.engine(size)?;
    engine.set_scale_search(args.scale_range()?);
    let pa = images::place(ia, a, size, args.fit)?;
    let pb = images::place(ib, b, size, args.fit)?;
    for (name, p) in [(a, &pa), (b, &pb)] {
        if p.cropped > 0 {
            eprintln!(
                "hough-heading: {}: {} occupied pixel(s) outside the {size}×{size} grid were cropped",
                name,
                p.cropped
            );
        }
    }
    engine.load(View::First, &pa.image);
    engine.load(View::Second, &pb.image);
    Ok((engine, [pa.offset, pb.offset]))
}

/// Estimates on two loaded images; the translation is mapped back to the
/// images' own centred coordinates.
pub fn images_result(
    engine: &mut dyn Engine,
    mode: Mode,
    offsets: [(f64, f64); 2],
) -> ImagesResult {
    let e = engine.estimate(mode);
    images_answer(&e, engine.size(), engine.n_theta(), offsets)
}

/// The `images` answer of an estimate on two grids of `size` cells and
/// `n_theta` θ steps (also for an estimate against a prepared reference);
/// the translation is mapped back to the images' own centred coordinates.
pub fn images_answer(
    e: &Estimate,
    size: usize,
    n_theta: usize,
    offsets: [(f64, f64); 2],
) -> ImagesResult {
    let alpha = f64::from(e.alpha.to_degrees());
    let t = e.translation.map(|t| {
        images::unplace_translation(
            (t.x.to_num::<f64>(), t.y.to_num::<f64>()),
            alpha.to_radians(),
            t.scale.to_num(),
            offsets[0],
            offsets[1],
        )
    });
    ImagesResult {
        alpha_deg: scans::round(alpha, 4),
        status: scans::status_name(e.status),
        confidence: scans::round(e.confidence.to_num::<f64>(), 4),
        candidates: e
            .candidates
            .iter()
            .map(|c| CandidateJson {
                alpha_deg: scans::round(f64::from(c.alpha.to_degrees()), 4),
                score: scans::round(c.score.to_num::<f64>(), 4),
                alignment: c.alignment.map(|a| scans::round(a.to_num::<f64>(), 4)),
                support: c.support.map(|a| scans::round(a.to_num::<f64>(), 4)),
            })
            .collect(),
        overlap: e
            .candidates
            .iter()
            .any(|c| c.alignment.is_some())
            .then(|| scans::round(e.overlap.to_num::<f64>(), 4)),
        tx_px: t.map(|t| scans::round(t.0, 3)),
        ty_px: t.map(|t| scans::round(t.1, 3)),
        scale: e
            .translation
            .map(|t| scans::round(t.scale.to_num::<f64>(), 4)),
        residual_px: e
            .translation
            .map(|t| scans::round(t.residual.to_num::<f64>(), 3)),
        columns: e.translation.map(|t| t.columns),
        unobservable: e.translation.and_then(|t| t.unobservable).map(|(x, y)| {
            [
                scans::round(x.to_num::<f64>(), 4),
                scans::round(y.to_num::<f64>(), 4),
            ]
        }),
        size,
        n_theta,
    }
}

fn images_command(args: &ImagesArgs) -> Result<(), Fatal> {
    let (mut engine, offsets) = load_images(&args.a, &args.b, &args.image, &args.estimator)?;
    let r = images_result(engine.as_mut(), args.estimator.mode.into(), offsets);
    let text = if args.json {
        serde_json::to_string(&r).map_err(|e| Fatal::io(format!("JSON output: {e}")))?
    } else {
        describe_images(&r, args.estimator.mode)
    };
    println!("{text}");
    Ok(())
}

/// The human-readable report of an `images` result.
pub fn describe_images(r: &ImagesResult, mode: ModeArg) -> String {
    let candidates: Vec<String> = r
        .candidates
        .iter()
        .map(|c| match c.alignment {
            Some(a) => format!("{:+.2}° (alignment {a:.2})", c.alpha_deg),
            None => format!("{:+.2}° ({:.2})", c.alpha_deg, c.score),
        })
        .collect();
    let translation = match (r.tx_px, r.ty_px) {
        (Some(x), Some(y)) => {
            let mut text = format!("tx = {x:+.2} px, ty = {y:+.2} px (x right, y up)");
            if let Some(residual) = r.residual_px {
                text.push_str(&format!(", residual {residual:.2} px"));
            }
            match r.columns {
                Some(c @ 3..) => text.push_str(&format!(" over {c} columns")),
                Some(c) => text.push_str(&format!(" over {c} column(s): not cross-checked")),
                None => {}
            }
            if let Some([ux, uy]) = r.unobservable {
                text.push_str(&format!(
                    "; not observable along ({ux:+.2}, {uy:+.2}): only the component across it"
                ));
            }
            text
        }
        _ => "not estimated (paper mode, or the rotation is not resolved)".into(),
    };
    let scale = match r.scale {
        Some(s) => format!("{s:.4}"),
        None => "–".into(),
    };
    let mode = match mode {
        ModeArg::Improved => "improved",
        ModeArg::Paper => "paper",
    };
    format!(
        "rotation of B relative to A: {:+.2}° (counter-clockwise)\n\
         status:      {} (confidence {:.2}{})\n\
         candidates:  {}\n\
         translation: {translation}\n\
         scale:       {scale}\n\
         grid:        {size}×{size}, N_θ = {}, {mode} mode",
        r.alpha_deg,
        r.status,
        r.confidence,
        r.overlap
            .map_or(String::new(), |o| format!(", overlap {o:.2}")),
        candidates.join(", "),
        r.n_theta,
        size = r.size,
    )
}

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

fn scans_command(args: &ScansArgs) -> Result<usize, Fatal> {
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
    result: Result<Vec<scans::PairEstimate>, String>,
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
                scans::estimate(engine.as_mut(), pair, &options, &modes)
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
                        let with_methods: Vec<(Method, &scans::PairEstimate)> = modes
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
