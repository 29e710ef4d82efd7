//! The estimator's options as the tool parses them (`clap`), shared with
//! the Python package, which parses its option lists with the same
//! definitions: an answer there equals the tool's.

use clap::{Args, ValueEnum};
use hough_heading::{Mode, ScaleRange, Score, Thresholds};

use crate::engine::{engine, Engine, CONFIGURATIONS};
use crate::error::Fatal;
use crate::image::Fit;
use crate::pairs::{RasterOptions, DEFAULT_CONNECT_M};

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
    #[arg(long, value_name = "METRES", default_value_t = DEFAULT_CONNECT_M)]
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
    pub fn options(&self, beams: &BeamArgs) -> Result<RasterOptions, Fatal> {
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
